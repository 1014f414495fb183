#!/usr/bin/env python3
"""Scorecard of `gearvib diagnose` on the hold-out recordings of gen_holdout.py (Python 3 standard library only).

Runs the release binary as a user would, on every machine directory under --data:
  speed source: `--rpm NOMINAL` (the nameplate speed: true speed + motor slip, rounded to 10 rpm),
                `--tacho-channel 2`, or nothing (teeth only); the nameplate and teeth-only modes read a
                vibration-only copy of the file (channel 1 alone, DATA/mono/): given the two-channel file,
                gearvib takes a sidecar's tachometer, with or without a given speed
  baseline:     none, `--baseline healthy-s1.wav` (one sibling), or `--profile` learned from healthy-s1 and -s2
                (`learn H1 H2 --channel 1 --teeth ZP,ZW SPEED -o P`; `diagnose REC --json --profile P`: the profile
                fixes channel, teeth and speed source and refuses them on the command line)
otherwise `diagnose REC --json --channel 1 --teeth ZP,ZW SPEED [--baseline H1]`. Healthy recordings judged: all three without a
baseline, s2 and s3 against s1, s3 against the profile. Every JSON line and stderr is kept under
--data/results/MODE/MACHINE/, the table and one line per miss go to stdout. With --same-load every run
against a baseline or profile says the baseline was recorded at the recording's load (`diagnose
--same-load`: a single sibling's limits are then its own blocks'; two siblings' change nothing).

Usage: score_holdout.py [--data /tmp/holdout] [--bin target/release/gearvib] [--jobs 2] [--reuse] [--same-load]
"""

import argparse
import concurrent.futures as cf
import glob
import json
import os
import struct
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_BIN = os.path.join(HERE, "..", "..", "target", "release", "gearvib")

SPEEDS = ["rpm", "tacho", "teeth"]
BASES = ["none", "H1", "profile"]
BASELINE_FLAGS = []  # added to every run against a baseline or profile (--same-load)


def mono_copy(src, dst):
    """The accelerometer channel alone (a vibration-only file: no tachometer anywhere), with a one-channel
    sidecar when the source has one."""
    if os.path.exists(dst):
        return
    with open(src, "rb") as f:
        b = f.read()
    pos, fmt, data = 12, None, None
    while pos + 8 <= len(b):
        cid, size = b[pos : pos + 4], struct.unpack("<I", b[pos + 4 : pos + 8])[0]
        if cid == b"fmt ":
            fmt = b[pos + 8 : pos + 8 + size]
        elif cid == b"data":
            data = b[pos + 8 : pos + 8 + size]
        pos += 8 + size + (size & 1)
    tag, ch, fs, _, block, bits = struct.unpack("<HHIIHH", fmt[:16])
    w = bits // 8
    mono = b"".join(data[i : i + w] for i in range(0, len(data), block))
    hdr = b"RIFF" + struct.pack("<I", 36 + len(mono)) + b"WAVE"
    hdr += b"fmt " + struct.pack("<IHHIIHH", 16, tag, 1, fs, fs * w, w, bits) + b"data" + struct.pack("<I", len(mono))
    os.makedirs(os.path.dirname(dst), exist_ok=True)
    with open(dst + ".tmp", "wb") as f:
        f.write(hdr + mono)
    if os.path.exists(src + ".json"):
        with open(src + ".json") as f:
            side = json.load(f)
        side["channels"] = side["channels"][:1]
        side["file"] = os.path.basename(dst)
        with open(dst + ".json", "w") as f:
            json.dump(side, f, indent=1)
    os.replace(dst + ".tmp", dst)


def rec_path(speed, tr, data):
    """The file a mode reads: the nameplate and teeth-only modes read a vibration-only (mono) copy."""
    if speed == "tacho":
        return tr["file"]
    dst = os.path.join(data, "mono", tr["machine"], os.path.basename(tr["file"]))
    mono_copy(tr["file"], dst)
    return dst


def speed_flags(speed, truth):
    if speed == "rpm":
        return ["--rpm", "%g" % truth["nominal_rpm"]]
    if speed == "tacho":
        return ["--tacho-channel", "2"]
    return []


def run(cmd, out_json, out_err, reuse):
    if reuse and os.path.exists(out_json):
        with open(out_err) as f:
            rc = int(f.readline().split("=", 1)[1])
        return rc
    p = subprocess.run(cmd, capture_output=True, text=True)
    with open(out_json, "w") as f:
        f.write(p.stdout)
    with open(out_err, "w") as f:
        f.write("rc=%d\n%s\n%s" % (p.returncode, " ".join(cmd), p.stderr))
    return p.returncode


def machine_jobs(mdir, binary, results, reuse, data):
    """Learns the profiles (sequentially, they are needed first) and returns the diagnose jobs."""
    truths = {}
    for t in sorted(glob.glob(os.path.join(mdir, "*.truth.json"))):
        with open(t) as f:
            tr = json.load(f)
        truths[os.path.basename(t)[: -len(".truth.json")]] = tr
    mname = os.path.basename(mdir)
    any_t = next(iter(truths.values()))
    teeth = "%d,%d" % (any_t["zp"], any_t["zw"])
    jobs = []
    for speed in SPEEDS:
        for base in BASES:
            odir = os.path.join(results, "%s-%s" % (speed, base), mname)
            os.makedirs(odir, exist_ok=True)
            bflags = []
            if base == "H1":
                bflags = ["--baseline", rec_path(speed, truths["healthy-s1"], data)]
            elif base == "profile":
                prof = os.path.join(odir, "profile.json")
                cmd = [binary, "learn", rec_path(speed, truths["healthy-s1"], data)]
                cmd += [rec_path(speed, truths["healthy-s2"], data)]
                cmd += ["--channel", "1", "--teeth", teeth] + speed_flags(speed, any_t) + ["-o", prof]
                if not (reuse and os.path.exists(prof)):
                    p = subprocess.run(cmd, capture_output=True, text=True)
                    with open(os.path.join(odir, "learn.err"), "w") as f:
                        f.write("rc=%d\n%s\n%s" % (p.returncode, " ".join(cmd), p.stderr))
                bflags = ["--profile", prof]
            for name, tr in truths.items():
                if tr["fault"] is None:
                    if base == "H1" and name == "healthy-s1":
                        continue
                    if base == "profile" and name in ("healthy-s1", "healthy-s2"):
                        continue
                cmd = [binary, "diagnose", rec_path(speed, tr, data), "--json"]
                if base != "profile":  # the profile fixes channel, teeth and speed source (learned with them)
                    cmd += ["--channel", "1", "--teeth", teeth] + speed_flags(speed, tr)
                cmd += bflags + (BASELINE_FLAGS if bflags else [])
                jobs.append(
                    dict(
                        mode="%s-%s" % (speed, base),
                        machine=mname,
                        name=name,
                        truth=tr,
                        cmd=cmd,
                        json=os.path.join(odir, name + ".json"),
                        err=os.path.join(odir, name + ".err"),
                    )
                )
    return jobs


def outcome(job, rc):
    res = dict(rc=rc, state="error", gear=None, tooth=None, origin=None, speed=None, source=None, reason="")
    try:
        with open(job["json"]) as f:
            line = f.readline()
        d = json.loads(line) if line.strip() else {}
    except (OSError, ValueError):
        d = {}
    if "verdict" in d:
        v = d["verdict"]
        res.update(
            state=v.get("state"),
            gear=v.get("gear"),
            tooth=v.get("tooth"),
            origin=v.get("tooth_origin"),
            speed=(d.get("shaft_hz") or {}).get("pinion"),
            source=d.get("speed_source"),
            reason=(v.get("reasons") or [""])[0],
            doubt=d.get("speed_doubt"),
            cross=v.get("cross_talk") or [],
        )
    else:
        with open(job["err"]) as f:
            lines = f.read().splitlines()
        res["reason"] = (d.get("error") if d else None) or (lines[2] if len(lines) > 2 else "")
    return res


def tooth_ok(truth, res):
    if truth["tooth"] is None or res["tooth"] is None or res["gear"] != truth["gear"]:
        return None
    if "tacho" not in (res["origin"] or ""):
        return None  # counted from an arbitrary origin: not comparable
    z = truth["zp"] if truth["gear"] == "pinion" else truth["zw"]
    d = abs(res["tooth"] - truth["tooth"]) % z
    return min(d, z - d)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", default="/tmp/holdout")
    ap.add_argument("--bin", default=DEFAULT_BIN)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--reuse", action="store_true", help="keep results already on disk")
    ap.add_argument("--speeds", default=",".join(SPEEDS), help="speed sources scored: rpm,tacho,teeth")
    ap.add_argument("--machines", default="", help="machines scored, e.g. m1,m3 (default: every one)")
    ap.add_argument("--same-load", action="store_true", help="runs against a baseline say it was at their load")
    a = ap.parse_args()
    BASELINE_FLAGS[:] = ["--same-load"] if a.same_load else []
    SPEEDS[:] = [m for m in a.speeds.split(",") if m in SPEEDS]
    binary = os.path.abspath(a.bin)
    results = os.path.join(a.data, "results")
    mdirs = sorted(d for d in glob.glob(os.path.join(a.data, "m[0-9]*")) if os.path.isdir(d))
    if a.machines:
        keep = a.machines.split(",")
        mdirs = [d for d in mdirs if os.path.basename(d).split("-")[0] in keep]
    jobs = []
    for m in mdirs:
        jobs += machine_jobs(m, binary, results, a.reuse, a.data)
    with cf.ThreadPoolExecutor(a.jobs) as ex:
        rcs = list(ex.map(lambda j: run(j["cmd"], j["json"], j["err"], a.reuse), jobs))
    for j, rc in zip(jobs, rcs):
        j["res"] = outcome(j, rc)
    report(jobs, mdirs)
    return 0


def report(jobs, mdirs):
    truths = {}
    for j in jobs:
        truths[(j["machine"], j["name"])] = j["truth"]
    print("gearvib hold-out scorecard (tests/holdout: gen_holdout.py physics, score_holdout.py)")
    print("machines:")
    for m in mdirs:
        t = truths[(os.path.basename(m), "healthy-s1")]
        print(
            "  %s: %d/%d teeth, fs %g Hz, %s%s, true %.2f Hz (nameplate %g rpm = %.2f Hz), speed fluct %.1f %%,"
            " load fluct %.1f %%, noise %.2f x rms, aux mesh %.0f Hz, contact ratio %.2f"
            % (
                os.path.basename(m),
                t["zp"],
                t["zw"],
                t["fs"],
                t["format"],
                " + sidecar" if t["sidecar"] else " plain WAV (no sidecar, no unit)",
                t["true_mean_speed_hz"],
                t["nominal_rpm"],
                t["nominal_speed_hz"],
                100 * t["speed_fluctuation"],
                100 * t["load_fluctuation"],
                t["noise_rel"],
                t["aux_mesh_hz"],
                t["contact_ratio"],
            )
        )
    print()
    hdr = "%-16s %6s %7s %8s %7s %9s %9s %7s %9s %9s %6s %9s" % (
        "mode",
        "faults",
        "FAULTY",
        "F|S",
        "gear ok",
        "tooth=",
        "tooth+-1",
        "healthy",
        "hlt FAULTY",
        "hlt SUSP",
        "n.j./err",
        "speed off",
    )
    print("per mode (F|S = FAULTY or SUSPECT; gear ok and tooth among F|S; tooth compared when named from the "
          "tachometer; n.j./err = not judged or error, faults + healthy; speed off = pinion speed used more than 0.5 % from the true mean)")
    print(hdr)
    modes = ["%s-%s" % (s, b) for s in SPEEDS for b in BASES]
    for mode in modes:
        js = [j for j in jobs if j["mode"] == mode]
        fa = [j for j in js if j["truth"]["fault"] is not None]
        he = [j for j in js if j["truth"]["fault"] is None]
        flagged = [j for j in fa if j["res"]["state"] in ("faulty", "suspect")]
        faulty = [j for j in fa if j["res"]["state"] == "faulty"]
        gear_ok = [j for j in flagged if j["res"]["gear"] == j["truth"]["gear"]]
        with_tooth = [j for j in gear_ok if j["truth"]["tooth"] is not None]
        t_named = [j for j in with_tooth if tooth_ok(j["truth"], j["res"]) is not None]
        t_exact = [j for j in t_named if tooth_ok(j["truth"], j["res"]) == 0]
        t_near = [j for j in t_named if tooth_ok(j["truth"], j["res"]) <= 1]
        hf = [j for j in he if j["res"]["state"] == "faulty"]
        hs = [j for j in he if j["res"]["state"] == "suspect"]
        nj = [j for j in js if j["res"]["state"] in ("not_judged", "error", None)]
        off = [
            j
            for j in js
            if j["res"]["speed"] and abs(j["res"]["speed"] / j["truth"]["true_mean_speed_hz"] - 1) > 0.005
        ]
        print(
            "%-16s %6d %7d %8d %7d %5d/%-3d %5d/%-3d %7d %9d %9d %6d %9d"
            % (
                mode,
                len(fa),
                len(faulty),
                len(flagged),
                len(gear_ok),
                len(t_exact),
                len(t_named),
                len(t_near),
                len(t_named),
                len(he),
                len(hf),
                len(hs),
                len(nj),
                len(off),
            )
        )
    print()
    print("per machine, faults flagged F|S / on the right gear (of 8), healthy flagged F|S after the '+', by mode:")
    mnames = [os.path.basename(m) for m in mdirs]
    print("%-16s " % "mode" + " ".join("%10s" % m[:10] for m in mnames))
    for mode in modes:
        row = []
        for m in mnames:
            js = [j for j in jobs if j["mode"] == mode and j["machine"] == m]
            fa = [j for j in js if j["truth"]["fault"] is not None]
            fl = [j for j in fa if j["res"]["state"] in ("faulty", "suspect")]
            go = [j for j in fl if j["res"]["gear"] == j["truth"]["gear"]]
            hf = [j for j in js if j["truth"]["fault"] is None and j["res"]["state"] in ("faulty", "suspect")]
            row.append("%d/%d+%d" % (len(fl), len(go), len(hf)))
        print("%-16s " % mode + " ".join("%10s" % x for x in row))
    print()
    print("per fault kind, flagged F|S / on the right gear (all machines), by mode:")
    kinds = []
    for j in jobs:
        t = j["truth"]
        if t["fault"] is not None:
            k = t["fault"] + ("%d" % round(100 * t["severity"]) if t["fault"] == "crack" else "")
            if k not in kinds:
                kinds.append(k)
    print("%-16s " % "mode" + " ".join("%13s" % k for k in kinds))
    for mode in modes:
        row = []
        for k in kinds:
            js = [
                j
                for j in jobs
                if j["mode"] == mode
                and j["truth"]["fault"] is not None
                and (j["truth"]["fault"] + ("%d" % round(100 * j["truth"]["severity"]) if j["truth"]["fault"] == "crack" else "")) == k
            ]
            fl = [j for j in js if j["res"]["state"] in ("faulty", "suspect")]
            go = [j for j in fl if j["res"]["gear"] == j["truth"]["gear"]]
            row.append("%4d/%-2d of %-2d" % (len(fl), len(go), len(js)))
        print("%-16s " % mode + " ".join("%13s" % x for x in row))
    print()
    print("every recording: state/gear/tooth per mode (F faulty, S suspect, H healthy, N not judged, E error;")
    print("p/w gear named, e 'pinion or wheel' (a 1:1 pair), u unknown; digits: tooth named; * wrong gear; speed error in % of the true mean when > 2.5 %)")
    print("%-32s " % "recording" + " ".join("%14s" % m for m in modes))
    keys = sorted(truths)
    for key in keys:
        t = truths[key]
        label = "%s/%s%s" % (key[0].split("-")[0], key[1], "" if t["tooth"] is None else " t%d" % t["tooth"])
        cells = []
        for mode in modes:
            js = [j for j in jobs if j["mode"] == mode and (j["machine"], j["name"]) == key]
            if not js:
                cells.append("-")
                continue
            r = js[0]["res"]
            c = {"faulty": "F", "suspect": "S", "healthy": "H", "not_judged": "N"}.get(r["state"], "E")
            if r["state"] in ("faulty", "suspect"):
                g = r["gear"] or "?"
                c += "e" if g == "pinion or wheel" else g[0]
                if t["gear"] is not None and r["gear"] != t["gear"]:
                    c += "*"
                if r["tooth"] is not None:
                    c += str(r["tooth"])
            if r["speed"]:
                err = 100 * (r["speed"] / t["true_mean_speed_hz"] - 1)
                if abs(err) > 2.5:
                    c += "(%+.0f%%)" % err
            cells.append(c)
        print("%-32s " % label + " ".join("%14s" % c for c in cells))
    print()
    print("misses (a fault not flagged, flagged on the wrong gear, a healthy one flagged, not judged, errors):")
    for j in jobs:
        t, r = j["truth"], j["res"]
        bad = False
        if t["fault"] is not None:
            bad = r["state"] not in ("faulty", "suspect") or r["gear"] != t["gear"]
        else:
            bad = r["state"] != "healthy"
        if not bad:
            continue
        sp = r["speed"]
        spe = "" if not sp else "%.3f Hz (%+.2f %% of true %.3f, src %s)" % (
            sp,
            100 * (sp / t["true_mean_speed_hz"] - 1),
            t["true_mean_speed_hz"],
            r["source"],
        )
        print(
            "  %-14s %s/%s: %s %s | speed %s | %s"
            % (j["mode"], j["machine"], j["name"], r["state"], r["gear"], spe, (r["reason"] or "")[:220])
        )


if __name__ == "__main__":
    sys.exit(main())
