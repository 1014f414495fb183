#!/usr/bin/env python3
"""How visible is each hold-out fault to a plain tachometer TSA? (numpy only; independent of gearvib)

Per recording and gear: the time-synchronous average over that gear's revolutions (angle from the
tachometer's rising edges, linear interpolation), then
  sb    first-sideband energy over mesh-harmonic energy (all mesh harmonics below Nyquist): eccentricity, wear
  kurt  kurtosis of the residual (the average less the mesh harmonics, orders 0-2 around each and their +-2)
  pitch the residual's largest tooth-pitch energy over the median pitch's, and which tooth (1-based, from
        the first edge): a local fault
Compare a fault's numbers with its machine's three healthy recordings.

Usage: visibility.py DIR... (machine directories written by gen_holdout.py)
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
        cid, size = b[pos : pos + 4], struct.unpack("<I", b[pos + 4 : pos + 8])[0]
        if cid == b"fmt ":
            fmt = b[pos + 8 : pos + 8 + size]
        elif cid == b"data":
            data = b[pos + 8 : pos + 8 + size]
        pos += 8 + size + (size & 1)
    tag, ch, fs = struct.unpack("<HHI", fmt[:8])
    x = np.frombuffer(data, "<f4" if tag == 3 else "<i2").reshape(-1, ch).astype(float)
    return x, float(fs)


def edges(tach, fs):
    thr = (tach.max() + tach.min()) / 2
    high = tach > thr
    e = np.flatnonzero(~high[:-1] & high[1:]) + 1
    return (e - 1 + (thr - tach[e - 1]) / (tach[e] - tach[e - 1])) / fs


def tsa(y, fs, tedge, ratio, npts):
    """Average over whole revolutions of a gear turning `ratio` times per input revolution."""
    ts = np.arange(len(y)) / fs
    revs = np.arange(len(tedge))
    out = []
    for g in range(int(np.floor((len(tedge) - 1) * ratio))):
        t = np.interp((g + np.arange(npts) / npts) / ratio, revs, tedge)
        out.append(np.interp(t, ts, y))
    return np.mean(out, 0)


def features(path):
    x, fs = read_wav(path)
    with open(path[:-4] + ".truth.json") as f:
        tr = json.load(f)
    y, te = x[:, 0], edges(x[:, 1], fs)
    res = {}
    for gear, z, ratio in (("pinion", tr["zp"], 1.0), ("wheel", tr["zw"], tr["zp"] / tr["zw"])):
        npts = 2 ** int(np.ceil(np.log2(fs / tr["true_mean_speed_hz"] / ratio)))
        X = np.fft.rfft(tsa(y, fs, te, ratio, npts))
        kmax = (npts // 2 - 2) // z
        mesh = sum(abs(X[k * z]) ** 2 for k in range(1, kmax))
        sb = sum(abs(X[k * z - 1]) ** 2 + abs(X[k * z + 1]) ** 2 for k in range(1, kmax))
        R = X.copy()
        for k in range(kmax + 1):
            for o in range(-2, 3):
                if 0 <= k * z + o < len(R):
                    R[k * z + o] = 0
        r = np.fft.irfft(R, npts)
        en = np.array([s.sum() for s in np.array_split(r**2, z)])
        res[gear] = (sb / mesh, ((r - r.mean()) ** 4).mean() / r.var() ** 2, en.max() / np.median(en), int(en.argmax()) + 1)
    return tr, res


def main():
    for d in sys.argv[1:]:
        for p in sorted(glob.glob(os.path.join(d, "*.wav"))):
            tr, r = features(p)
            cells = " ".join("%s: sb %.3f kurt %5.1f pitch %6.1f@%-3d" % ((g[0],) + v) for g, v in r.items())
            print("%-10s %-20s %s | truth %s %s" % (os.path.basename(d)[:9], os.path.basename(p)[:-4], cells, tr["gear"], tr["tooth"]))


if __name__ == "__main__":
    main()
