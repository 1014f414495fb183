#!/usr/bin/env python3
"""Every generated machine's profile against every other machine's healthy recording (standard library only).

A profile must not clear a machine it was not learned on. For each machine directory of the given sets
(made by gen_holdout.py, gen_third.py or gen_fourth.py), a profile is learned from the vibration-only copies
of healthy-s1 and healthy-s2 with the nameplate speed, as the scorecard's profile mode does
(`learn H1 H2 --channel 1 --teeth ZP,ZW --rpm NOMINAL -o P`), and every other machine's healthy-s3
(vibration only) is judged with it (`diagnose REC --json --profile P`). Refused (exit 2: the sample rate,
speed or unit does not fit) and not judged (exit 3) are right; suspect and faulty at least say "look";
HEALTHY is wrong. Prints the count of each outcome and every healthy and faulty run.

Usage: cross_machines.py --data SET [--data SET ...] [--bin target/release/gearvib] [--jobs 2]
"""

import argparse
import collections
import concurrent.futures as cf
import glob
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from score_holdout import rec_path  # noqa: E402  (the scorecard's vibration-only copies)

DEFAULT_BIN = os.path.join(HERE, "..", "..", "target", "release", "gearvib")


def machines(sets):
    """(name, set dir, {healthy-s1/-s2/-s3: truth}) of every machine."""
    out = []
    for data in sets:
        for mdir in sorted(glob.glob(os.path.join(data, "m*-z*"))):
            truths = {}
            for name in ("healthy-s1", "healthy-s2", "healthy-s3"):
                with open(os.path.join(mdir, name + ".truth.json")) as f:
                    truths[name] = json.load(f)
            out.append((os.path.basename(mdir), data, truths))
    return out


def learn(binary, m, into):
    name, data, t = m
    prof = os.path.join(into, name + ".json")
    teeth = "%d,%d" % (t["healthy-s1"]["zp"], t["healthy-s1"]["zw"])
    cmd = [binary, "learn", rec_path("rpm", t["healthy-s1"], data), rec_path("rpm", t["healthy-s2"], data)]
    cmd += ["--channel", "1", "--teeth", teeth, "--rpm", "%g" % t["healthy-s1"]["nominal_rpm"], "-o", prof]
    p = subprocess.run(cmd, capture_output=True, text=True)
    return prof if p.returncode == 0 else None


def judge(binary, prof, m):
    name, data, t = m
    p = subprocess.run(
        [binary, "diagnose", rec_path("rpm", t["healthy-s3"], data), "--json", "--profile", prof],
        capture_output=True,
        text=True,
    )
    try:
        d = json.loads(p.stdout.splitlines()[0])
    except (IndexError, json.JSONDecodeError):
        return "error", p.stderr.strip()[:160]
    if "verdict" not in d:
        return "refused", d.get("error", "")[:160]
    return d["verdict"]["state"], (d["verdict"]["reasons"] or [""])[0][:160]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", action="append", required=True)
    ap.add_argument("--bin", default=DEFAULT_BIN)
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    ms = machines(a.data)
    with tempfile.TemporaryDirectory() as into, cf.ThreadPoolExecutor(a.jobs) as ex:
        profs = dict(zip((m[0] for m in ms), ex.map(lambda m: learn(a.bin, m, into), ms)))
        pairs = [(p, m) for p in ms for m in ms if p[0] != m[0] and profs[p[0]]]
        results = list(ex.map(lambda pm: judge(a.bin, profs[pm[0][0]], pm[1]), pairs))
    tally = collections.Counter(state for state, _ in results)
    print("%d cross runs: %s" % (len(results), ", ".join("%s %d" % kv for kv in sorted(tally.items()))))
    for (p, m), (state, why) in zip(pairs, results):
        if state in ("healthy", "faulty", "error"):
            print("  profile %-12s on %-12s %-8s | %s" % (p[0], m[0], state, why))
    unlearned = [name for name, prof in profs.items() if prof is None]
    if unlearned:
        print("profiles that could not be learned: " + ", ".join(unlearned))


if __name__ == "__main__":
    main()
