#!/usr/bin/env python3
"""Own visibility check of the third generator's faults (numpy only; independent of gearvib).

Per recording and gear: a plain time-synchronous average over that gear's revolutions (angle from the
tachometer's rising mid-level crossings, linear interpolation between edges), then
  mesh   the mesh harmonics' share of the TSA energy
  sb     energy of sidebands +-1..3 around the mesh harmonics / mesh-harmonic energy
  ord1   energy of orders 1-2 of this gear / mesh-harmonic energy (eccentricity)
  FM4    kurtosis of the difference signal (TSA minus mesh harmonics and their +-1 sidebands)
  kres   kurtosis of the residual (TSA minus mesh harmonics, +-2 around each, and orders 0-2)
  pitch  the residual's largest tooth-pitch energy / median pitch energy, and that tooth (1-based from the
         gear's origin: the first rising edge)
  z      for each indicator, the fault's value minus the mean of the machine's 3 healthy, over their spread
         (spread floored at 10 % of the mean), printed as 'dX'
Also prints, per machine, the raw spectrum's first mesh harmonics over their local floor (dB).

Usage: check_visibility.py DIR...
"""

import glob
import json
import os
import struct
import sys

import numpy as np


def read_wav(path):
    with open(path, "rb") as f:
        b = f.read()
    pos, fmt, data = 12, None, None
    while pos + 8 <= len(b):
        cid, size = b[pos:pos + 4], struct.unpack("<I", b[pos + 4:pos + 8])[0]
        if cid == b"fmt ":
            fmt = b[pos + 8:pos + 8 + size]
        elif cid == b"data":
            data = b[pos + 8:pos + 8 + size]
        pos += 8 + size + (size & 1)
    tag, ch, fs = struct.unpack("<HHI", fmt[:8])
    bits = struct.unpack("<H", fmt[14:16])[0]
    if tag == 3:
        x = np.frombuffer(data, "<f4")
    elif bits == 16:
        x = np.frombuffer(data, "<i2").astype(float)
    elif bits == 24:
        u = np.frombuffer(data, np.uint8).reshape(-1, 3).astype(np.int32)
        v = u[:, 0] | (u[:, 1] << 8) | (u[:, 2] << 16)
        x = np.where(v >= 1 << 23, v - (1 << 24), v).astype(float)
    else:
        raise ValueError(bits)
    return x.reshape(-1, ch).astype(float), float(fs)


def edges(tach, fs):
    thr = (tach.max() + tach.min()) / 2
    hi = tach >= thr
    e = np.flatnonzero(~hi[:-1] & hi[1:])
    return (e + (thr - tach[e]) / (tach[e + 1] - tach[e])) / fs


def tsa(y, fs, tedge, ratio, npts):
    ts = np.arange(len(y)) / fs
    revs = np.arange(len(tedge))
    ng = int(np.floor((len(tedge) - 1) * ratio))
    grid = (np.arange(ng)[:, None] + np.arange(npts)[None, :] / npts) / ratio
    t = np.interp(grid.ravel(), revs, tedge)
    return np.interp(t, ts, y).reshape(ng, npts).mean(0), ng


def kurt(x):
    x = x - x.mean()
    return float((x**4).mean() / max((x**2).mean() ** 2, 1e-300))


def features(path):
    x, fs = read_wav(path)
    with open(path[:-4] + ".truth.json") as f:
        tr = json.load(f)
    y = x[:, 0] - x[:, 0].mean()
    te = edges(x[:, 1], fs)
    out = {}
    for gear, z, ratio in (("pinion", tr["zp"], 1.0), ("wheel", tr["zw"], tr["zp"] / tr["zw"])):
        npts = 2 ** int(np.ceil(np.log2(0.9 * fs / tr["true_mean_speed_hz"] / ratio)))
        a, ng = tsa(y, fs, te, ratio, npts)
        X = np.fft.rfft(a)
        P = np.abs(X) ** 2
        kmax = int((0.42 * npts) // z)
        mesh_o = [k * z for k in range(1, kmax + 1)]
        mesh = sum(P[o] for o in mesh_o)
        sb = sum(P[o + d] for o in mesh_o for d in (-3, -2, -1, 1, 2, 3) if o + d < len(P))
        D = X.copy()
        D[: int(0.45 * npts)][:0] = 0
        for o in mesh_o:
            for d in (-1, 0, 1):
                if o + d < len(D):
                    D[o + d] = 0
        D[0] = 0
        D[int(0.45 * npts):] = 0
        dif = np.fft.irfft(D, npts)
        R = D.copy()
        for o in mesh_o:
            for d in (-2, 2):
                if o + d < len(R):
                    R[o + d] = 0
        R[:3] = 0
        res = np.fft.irfft(R, npts)
        en = np.array([s.sum() for s in np.array_split(res**2, z)])
        out[gear] = dict(mesh=mesh / P[1:].sum(), sb=sb / mesh, ord1=(P[1] + P[2]) / mesh, FM4=kurt(dif),
                         kres=kurt(res), pitch=en.max() / np.median(en), tooth=int(en.argmax()) + 1, navg=ng)
    # raw spectrum lines
    seg = 2 ** int(np.ceil(np.log2(fs * 2)))
    nseg = max(1, len(y) // seg)
    win = np.hanning(seg)
    S = np.mean([np.abs(np.fft.rfft(win * y[i * seg:(i + 1) * seg])) ** 2 for i in range(nseg)], 0)
    fr = np.fft.rfftfreq(seg, 1 / fs)
    fm = tr["true_mean_speed_hz"] * tr["zp"]
    lines = []
    for k in range(1, 9):
        f0 = k * fm
        if f0 > 0.45 * fs:
            break
        i = int(round(f0 / fr[1]))
        w = max(3, int(0.03 * f0 / fr[1]))  # +-1.5 % (speed fluctuation smears)
        pk = S[max(i - w, 1):i + w + 1].sum()
        lo, hi = max(i - 40 * w, 1), min(i + 40 * w, len(S))
        floor = np.median(S[lo:hi]) * (2 * w + 1)
        lines.append(10 * np.log10(pk / floor))
    return tr, out, lines


KEYS = ("sb", "ord1", "FM4", "kres", "pitch")


def main():
    for d in sys.argv[1:]:
        rows = []
        for p in sorted(glob.glob(os.path.join(d, "*.wav"))):
            rows.append((os.path.basename(p)[:-4],) + features(p))
        healthy = [r for r in rows if r[1]["fault"] is None]
        print("== %s (%d/%d teeth, fs %g)" % (os.path.basename(d), rows[0][1]["zp"], rows[0][1]["zw"], rows[0][1]["fs"]))
        h0 = healthy[0]
        print("   raw spectrum, mesh harmonics 1.. over local floor (dB), %s: %s" % (
            h0[0], " ".join("%.0f" % v for v in h0[3])))
        stats = {}
        for g in ("pinion", "wheel"):
            for k in KEYS:
                v = np.array([h[2][g][k] for h in healthy])
                stats[(g, k)] = (v.mean(), max(v.std(ddof=1) if len(v) > 1 else 0, 0.1 * abs(v.mean())))
        for name, tr, out, lines in rows:
            cells = []
            for g in ("pinion", "wheel"):
                o = out[g]
                zs = {k: (o[k] - stats[(g, k)][0]) / stats[(g, k)][1] for k in KEYS}
                cells.append("%s: sb %.3f(d%+.0f) o12 %.3f(d%+.0f) FM4 %.1f(d%+.0f) kres %.1f(d%+.0f) pitch %.1f@%d(d%+.0f)" % (
                    g[0], o["sb"], zs["sb"], o["ord1"], zs["ord1"], o["FM4"], zs["FM4"], o["kres"], zs["kres"],
                    o["pitch"], o["tooth"], zs["pitch"]))
            print("%-20s %s | truth %s %s %s" % (name, " | ".join(cells), tr["fault"], tr["gear"], tr["tooth"]))


if __name__ == "__main__":
    main()
