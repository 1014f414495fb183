#!/usr/bin/env python3
"""Healthy false alarms against a profile of two siblings, on more seeds than the scorecard holds.

The scorecard judges one healthy recording (s3) per machine against the profile of s1 and s2; this makes
eleven healthy recordings of each hold-out machine (gen_holdout.py's physics and seeds: s1-s3 are the
scorecard's own, s4-s11 new), learns the profile of s1 and s2 with the tachometer
(`learn H1 H2 --channel 1 --teeth ZP,ZW --tacho-channel 2`) and judges s3-s11 with it, printing the count
of each verdict and every recording not called healthy. numpy for the generation, the standard library
for the rest.

Usage: /tmp/hv/bin/python more_healthy.py [--out /tmp/extra] [--bin target/release/gearvib]
"""

import argparse
import collections
import concurrent.futures as cf
import glob
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)


def generate(out):
    import numpy as np

    import gen_holdout as g

    for m in g.MACHINES:
        p = g.machine_params(m)
        d = os.path.join(out, m["name"])
        os.makedirs(d, exist_ok=True)
        ref = None
        for i in range(11):
            seed = p["seed"] * 10 + i + 1
            y, tach, _, ref = g.synthesise(p, None, seed, ref)
            path = os.path.join(d, "healthy-s%d.wav" % (i + 1))
            data = np.stack([y, tach], 1)
            if m["fmt"] == "f32":
                g.write_wav(path, data, p["fs"], "f32")
                g.write_json(path + ".json", g.sidecar(path, p, len(y), seed))
            else:
                g.write_wav(path, data, p["fs"], "i16", [20.0 * ref["sig_rms"], 6.0])
        with open(os.path.join(d, "machine.json"), "w") as f:
            json.dump(dict(zp=p["zp"], zw=p["zw"]), f)


def judge(binary, out):
    jobs = []
    for d in sorted(glob.glob(os.path.join(out, "m*"))):
        with open(os.path.join(d, "machine.json")) as f:
            m = json.load(f)
        common = ["--channel", "1", "--teeth", "%d,%d" % (m["zp"], m["zw"]), "--tacho-channel", "2"]
        prof = os.path.join(d, "profile.json")
        h = [os.path.join(d, "healthy-s%d.wav" % i) for i in (1, 2)]
        subprocess.run([binary, "learn", *h, *common, "-o", prof], capture_output=True, check=True)
        for i in range(3, 12):
            rec = os.path.join(d, "healthy-s%d.wav" % i)
            jobs.append((os.path.basename(d), i, [binary, "diagnose", rec, "--json", "--profile", prof]))

    def run(job):
        machine, i, cmd = job
        r = subprocess.run(cmd, capture_output=True, text=True)
        try:
            v = json.loads(r.stdout.splitlines()[0])["verdict"]
            return machine, i, v["state"], v["reasons"][0][:200]
        except (IndexError, ValueError, KeyError):
            return machine, i, "error", r.stderr.strip()[:200]

    with cf.ThreadPoolExecutor(2) as ex:
        res = list(ex.map(run, jobs))
    print("verdicts of %d healthy recordings against the profile of two siblings:" % len(res),
          dict(collections.Counter(s for _, _, s, _ in res)))
    for machine, i, state, why in res:
        if state != "healthy":
            print("  %s/healthy-s%d: %s | %s" % (machine, i, state, why))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="/tmp/extra")
    ap.add_argument("--bin", default=os.path.join(HERE, "..", "..", "target", "release", "gearvib"))
    a = ap.parse_args()
    if not glob.glob(os.path.join(a.out, "m*", "machine.json")):
        generate(a.out)
    judge(a.bin, a.out)


if __name__ == "__main__":
    main()
