#!/usr/bin/env python3
"""Scorecard of `gearvib diagnose` on the SpectraQuest rig's 20 files (Python 3 standard library only).

The real rig (data/realdata/SOURCE.md) at every load from 0 to 90 %: `h30hzL.csv` healthy, `b30hzL.csv` one
broken tooth, sample rate and teeth unknown, so every run is `diagnose REC --fs-unknown --json`:
  broken-vs-own      b30hzL against h30hzL                      must be flagged (suspect or faulty)
  broken-alone       b30hzL without a baseline                  flagged or not (reported, no requirement)
  healthy-self       h30hzL against itself                      must be healthy
  healthy-alone      h30hzL without a baseline                  must be healthy
  healthy-vs-one     h30hzL against h30hz(L-10) and h30hz(L+10) must be healthy
  broken-vs-one      b30hzL against each of those               must be flagged
  healthy-vs-two     h30hzL against both neighbouring loads     must be healthy
  broken-vs-two      b30hzL against both neighbouring loads     must be flagged
  healthy-vs-rest    h30hzL against a profile learned from the nine other loads' healthy files (`learn`)
                                                                must be healthy
  broken-vs-rest     b30hzL against that profile                must be flagged
  broken-own-chN     b30hzL on channel N alone against h30hzL   flagged or not (reported, no requirement)
  broken-own-chN-same  the same with --same-load (the file was recorded at that load): reported
The files are the same data set's copies in kokikwbt/predictive-maintenance `datasets/gfd/*.csv.gz`,
decompressed into --data (four of them, and three more loads, are in data/realdata). Nothing is written
but the table on stdout (and the profiles, in a temporary directory).

Usage: score_realdata.py --data DIR [--bin target/release/gearvib] [--jobs 2]
"""

import argparse
import collections
import concurrent.futures as cf
import json
import os
import subprocess
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_BIN = os.path.join(HERE, "..", "..", "target", "release", "gearvib")
LOADS = list(range(0, 100, 10))


def cases():
    """(kind, recording, baselines, requirement, further flags) for every comparison of the scorecard."""
    out = []
    for load in LOADS:
        near = [m for m in (load - 10, load + 10) if 0 <= m <= 90]
        out.append(("broken-vs-own", f"b30hz{load}", [f"h30hz{load}"], "flag"))
        out.append(("broken-alone", f"b30hz{load}", [], "any"))
        out.append(("healthy-self", f"h30hz{load}", [f"h30hz{load}"], "keep"))
        out.append(("healthy-alone", f"h30hz{load}", [], "keep"))
        for m in near:
            out.append(("healthy-vs-one", f"h30hz{load}", [f"h30hz{m}"], "keep"))
            out.append(("broken-vs-one", f"b30hz{load}", [f"h30hz{m}"], "flag"))
        if len(near) == 2:
            out.append(("healthy-vs-two", f"h30hz{load}", [f"h30hz{m}" for m in near], "keep"))
            out.append(("broken-vs-two", f"b30hz{load}", [f"h30hz{m}" for m in near], "flag"))
        out.append(("healthy-vs-rest", f"h30hz{load}", [f"profile-without-{load}"], "keep"))
        out.append(("broken-vs-rest", f"b30hz{load}", [f"profile-without-{load}"], "flag"))
    # one channel alone against the healthy file of its own load, without and with the word that the
    # file was recorded at that load (`--same-load`): reported, no requirement (a sensor may not see it)
    for same in (False, True):
        for ch in range(1, 5):
            kind = f"broken-own-ch{ch}" + ("-same" if same else "")
            flags = ["--channel", str(ch)] + (["--same-load"] if same else [])
            out += [(kind, f"b30hz{load}", [f"h30hz{load}"], "any", flags) for load in LOADS]
    return [c if len(c) == 5 else c + ([],) for c in out]


def learn_profiles(binary, data, into):
    """One profile per load, learned from the other loads' healthy files."""
    for load in LOADS:
        rest = [os.path.join(data, f"h30hz{m}.csv") for m in LOADS if m != load]
        out = os.path.join(into, f"profile-without-{load}.json")
        subprocess.run([binary, "learn", *rest, "--fs-unknown", "-o", out], capture_output=True, check=True)


def run(binary, data, profiles, case):
    """The verdict of one case: (state, gear, first reason, exit code)."""
    _, rec, bases, _, flags = case
    cmd = [binary, "diagnose", os.path.join(data, rec + ".csv"), "--json", *flags]
    if bases and bases[0].startswith("profile-"):
        cmd += ["--profile", os.path.join(profiles, bases[0] + ".json")]
    else:
        cmd.append("--fs-unknown")
    for b in bases if not (bases and bases[0].startswith("profile-")) else []:
        cmd += ["--baseline", os.path.join(data, b + ".csv")]
    p = subprocess.run(cmd, capture_output=True, text=True)
    try:
        v = json.loads(p.stdout.splitlines()[0])["verdict"]
        return v["state"], v.get("gear", ""), (v.get("reasons") or [""])[0], p.returncode
    except (IndexError, KeyError, json.JSONDecodeError):
        return "error", "", p.stderr.strip(), p.returncode


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--bin", default=DEFAULT_BIN)
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    all_cases = cases()
    with tempfile.TemporaryDirectory() as profiles:
        learn_profiles(a.bin, a.data, profiles)
        with cf.ThreadPoolExecutor(a.jobs) as ex:
            results = list(ex.map(lambda c: run(a.bin, a.data, profiles, c), all_cases))
    tally = collections.OrderedDict()
    for case, (state, gear, reason, code) in zip(all_cases, results):
        kind, rec, bases, want, _ = case
        ok = {"flag": state in ("suspect", "faulty"), "keep": state == "healthy", "any": state != "error"}[want]
        t = tally.setdefault(kind, [0, 0, 0, want])
        t[0] += ok
        t[1] += 1
        t[2] += state in ("suspect", "faulty")
        base = "+".join(bases) or "-"
        print(f"{kind:15s} {rec:8s} {base:15s} {state:10s} {('ok ' if ok else 'BAD') if want != 'any' else '   '} exit {code} | {reason[:160]}")
    print()
    for kind, (ok, n, flagged, want) in tally.items():
        if want == "any":
            print(f"{kind}: {flagged} of {n} flagged (no requirement)")
        else:
            print(f"{kind}: {ok} of {n} as required")


if __name__ == "__main__":
    main()
