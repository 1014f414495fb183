#!/usr/bin/env python3
"""Hold-out gearbox recordings from a physics of their own (numpy only; calls no gearvib code).

A phenomenological + lumped hybrid, unlike tests/common/gearbox_gen.rs (a time-domain RK4 multi-DOF train):

1. Loaded transmission error, quasi-static, per tooth pair. The pair meshing around mesh position m = k + 1/2
   (m = input angle in revolutions x pinion teeth) is pinion tooth k mod zp with wheel tooth k mod zw; it is in
   contact over a mesh-position interval of the contact ratio eps (1.35-1.7). Each pair has a stiffness along
   its path (parabolic, 30 % lower at the ends) and a separation e(u) = pinion tooth pitch error + wheel tooth
   pitch error + each tooth's profile slope error + tip relief of both gears + fault terms (u = position
   along the path, -1/2..1/2). Under the load W the deflection d solves W = sum k_i (d - e_i) over the pairs
   actually touching (d > e_i: contact loss and tip relief make the contact ratio load dependent), iterated.
   When no pair touches (a broken tooth) the gears fly free: d grows parabolically until the next pair
   catches them, an impact. Eccentricity / run-out of either gear adds a once-per-revolution TE term.
2. The TE drives one single-DOF mesh oscillator (natural frequency 2-5.5 kHz, 5-10 % damping), applied
   exactly in the frequency domain; its force is amplitude-modulated by the load (3-8 % smooth random
   fluctuation) and by each gear's run-out (the transfer path turning with the gear).
3. Other sources: an auxiliary pair (oil pump or idler) on its own belt-driven shaft at an unrelated speed,
   with its own tooth errors; rolling-element broadband force (white, lightly modulated at a cage rate);
   a fan tone (blades x input shaft, 3 harmonics); random shocks (Poisson, half-sine force pulses).
4. All forces reach the accelerometer through a housing path of 2-4 resonances (1.5-9 kHz, 1.5-6 % damping),
   computed at twice the sample rate and decimated in the frequency domain with an anti-alias taper
   (0.42-0.5 fs), then 50/60 Hz hum with harmonics and white sensor noise at 0.3-0.8 of the healthy signal
   RMS are added (absolute levels per machine, fixed by its first healthy recording).
5. Speed: nominal x (1 + 100 ppm slow drift + 0.5-2 % smooth random fluctuation, 0.03-2 Hz); the angle is
   the integral of the speed. Channel 2 is a once-per-input-revolution TTL tachometer (0/5 V, high for 10 %
   of a revolution, 15 us edges, 2 us rms edge jitter, 20 mV noise), rising edge at input angle 0.

Tooth numbering: tooth n (1-based) of a gear is centred on the angle (n - 1/2)/z of a revolution after that
gear's angle origin. The input shaft's origin is the tachometer's rising edge; the wheel's origin is the
wheel angle at the FIRST rising edge in the file (the recording starts 0.1-0.9 revolution before it; at that
edge pinion and wheel angles are both 0). Truth files `NAME.truth.json` record machine, fault, gear, tooth,
severity, true mean speed and the nameplate (nominal) speed.

Output: per machine a directory with float32 WAV + gearvib sidecar (`NAME.wav.json`), or int16 WAV without
sidecar (a plain data-logger file), two channels (accelerometer m/s^2, tachometer V).

Usage: gen_holdout.py [--out /tmp/holdout] [--machines m1,m2,...] [--quick] [--fresh | --common]
"""

import argparse
import json
import os
import struct
import sys
import time

import numpy as np

# ---------------------------------------------------------------------------------------------------------
# machines: geometries, rates and speeds not in tests/common/gearbox_gen.rs (17/29, 23/41, 31/47, 19/37)

MACHINES = [
    dict(name="m1-z19z53", zp=19, zw=53, fs=20000.0, f1=22.0, T=12.0, fmt="f32", seed=101),
    dict(name="m2-z13z37", zp=13, zw=37, fs=48000.0, f1=38.0, T=10.0, fmt="i16", seed=202),
    dict(name="m3-z27z35", zp=27, zw=35, fs=51200.0, f1=13.5, T=16.0, fmt="f32", seed=303),
    dict(name="m4-z21z64", zp=21, zw=64, fs=25600.0, f1=29.0, T=12.0, fmt="i16", seed=404),
    dict(name="m5-z16z45", zp=16, zw=45, fs=44100.0, f1=17.3, T=15.0, fmt="f32", seed=505),
    dict(name="m6-z25z58", zp=25, zw=58, fs=32000.0, f1=31.5, T=10.0, fmt="f32", seed=606),
    # housings with low panel modes too (250-900 Hz): the first mesh harmonics are not under the w^2 roll-off
    dict(name="m7-z29z71", zp=29, zw=71, fs=40000.0, f1=24.0, T=12.0, fmt="f32", seed=707, panel=True),
    dict(name="m8-z15z52", zp=15, zw=52, fs=25600.0, f1=35.0, T=10.0, fmt="i16", seed=808, panel=True),
    dict(name="m9-z22z49", zp=22, zw=49, fs=51200.0, f1=16.0, T=16.0, fmt="f32", seed=909, panel=True),
]

# a fresh set (`--fresh`), made after every threshold above was set, to see how the diagnosis does on
# machines none of them was tuned on (twenty-sixth session): new geometries, rates, speeds and seeds; a fan of
# 10 blades on a 20-tooth pinion puts its second harmonic on the mesh, one on a 31-tooth pinion its third
# harmonic at order 30 beside it
FRESH_MACHINES = [
    dict(name="m10-z20z33", zp=20, zw=33, fs=24000.0, f1=33.0, T=12.0, fmt="f32", seed=1111),
    dict(name="m11-z24z37", zp=24, zw=37, fs=51200.0, f1=12.5, T=16.0, fmt="i16", seed=1212),
    dict(name="m12-z17z47", zp=17, zw=47, fs=32000.0, f1=21.0, T=12.0, fmt="f32", seed=1313, panel=True),
    dict(name="m13-z31z43", zp=31, zw=43, fs=44100.0, f1=19.0, T=12.0, fmt="f32", seed=1414),
    dict(name="m14-z18z29", zp=18, zw=29, fs=20000.0, f1=39.0, T=10.0, fmt="i16", seed=1515, panel=True),
]

# a third set (`--common`, twenty-eighth session): ratios with a common factor, which no set above has. A
# gear pair whose teeth share a factor repeats its tooth pairs every few revolutions, and with a whole
# ratio the wheel's orders fall on pinion orders: 20/40 and 18/54 (whole ratios 2 and 3), 24/36 (pairs
# repeat every 3 pinion revolutions) and 23/23 (1:1, where no period tells the two gears apart)
COMMON_MACHINES = [
    dict(name="m15-z20z40", zp=20, zw=40, fs=25600.0, f1=24.0, T=12.0, fmt="f32", seed=1616),
    dict(name="m16-z18z54", zp=18, zw=54, fs=48000.0, f1=30.0, T=12.0, fmt="i16", seed=1717, panel=True),
    dict(name="m17-z24z36", zp=24, zw=36, fs=32000.0, f1=16.0, T=14.0, fmt="f32", seed=1818),
    dict(name="m18-z23z23", zp=23, zw=23, fs=40000.0, f1=20.0, T=12.0, fmt="f32", seed=1919, panel=True),
]

# faults per machine; gear "A" / "B" alternate by machine index so both gears get every kind
FAULTS = [
    ("crack", 0.10, "A"),
    ("crack", 0.25, "B"),
    ("crack", 0.50, "A"),
    ("spall", 1.0, "B"),
    ("spall", 1.0, "A"),
    ("broken", 1.0, "B"),
    ("wear", 1.0, "A"),
    ("eccentricity", 1.0, "B"),
]

OVERSAMPLE = 2
STATIC_DEFLECTION_UM = 12.0  # one pair's deflection under the nominal load


# ---------------------------------------------------------------------------------------------------------
# machine-level parameters (fixed for every recording of a machine: the same physical gears)


def machine_params(m):
    r = np.random.default_rng(m["seed"])
    zp, zw = m["zp"], m["zw"]
    fs = m["fs"]
    p = dict(m)
    p["eps"] = r.uniform(1.35, 1.7)
    for g, z in (("p", zp), ("w", zw)):
        # cumulative pitch error: a once-per-revolution part plus a per-tooth random part (um)
        ang = (np.arange(z) + 0.5) / z
        p["pitch_" + g] = r.uniform(1.5, 3.5) * np.sin(2 * np.pi * ang + r.uniform(0, 2 * np.pi)) + r.normal(
            0, r.uniform(0.6, 1.4), z
        )
        p["slope_" + g] = r.normal(0, r.uniform(0.8, 1.8), z)  # profile slope error over the path (um)
        p["relief_" + g] = r.uniform(6.0, 14.0)  # tip relief depth (um)
        p["relief_len_" + g] = r.uniform(0.12, 0.22)  # its length (fraction of the path)
        p["runout_" + g] = r.uniform(1.0, 3.5)  # healthy run-out TE (um)
        p["runout_ph_" + g] = r.uniform(0, 2 * np.pi)
        p["am_" + g] = r.uniform(0.02, 0.06)  # transfer-path modulation per revolution
        p["am_ph_" + g] = r.uniform(0, 2 * np.pi)
    top = 0.45 * fs
    p["mesh_fn"] = r.uniform(2000.0, min(5500.0, 0.4 * fs))
    p["mesh_zeta"] = r.uniform(0.05, 0.10)
    nres = int(r.integers(2, 5))
    p["house_f"] = np.sort(r.uniform(1500.0, min(9000.0, top), nres))
    p["house_zeta"] = r.uniform(0.015, 0.06, nres)
    p["house_g"] = r.uniform(0.4, 1.0, nres) * r.choice([-1, 1], nres)
    # auxiliary pair (pump / idler) on its own shaft at an unrelated speed
    p["aux_ratio"] = r.uniform(0.55, 1.8) * (1 + r.uniform(0.01, 0.03))  # belt ratio with slip
    p["aux_zp"] = int(r.integers(11, 24))
    p["aux_zw"] = int(r.integers(25, 60))
    p["aux_gain"] = r.uniform(0.25, 0.6)
    p["aux_params"] = aux_pair_params(r, p["aux_zp"], p["aux_zw"])
    p["fan_blades"] = int(r.integers(5, 12))
    p["fan_gain"] = r.uniform(0.05, 0.2)
    p["bearing_gain"] = r.uniform(0.3, 0.6)  # broadband force RMS relative to the mesh force RMS
    p["cage_order"] = r.uniform(0.38, 0.44)
    p["shock_rate"] = r.uniform(0.3, 2.0)  # per second
    p["hum_hz"] = float(r.choice([50.0, 60.0]))
    p["hum_rel"] = r.uniform(0.05, 0.2)
    p["noise_rel"] = r.uniform(0.3, 0.8)
    p["speed_fluct"] = r.uniform(0.005, 0.02)
    p["load_fluct"] = r.uniform(0.03, 0.08)
    p["slip"] = r.uniform(0.005, 0.02)
    # nameplate speed: the true speed plus the motor's slip, rounded to 10 rpm
    p["nominal_rpm"] = float(round(m["f1"] * 60.0 * (1 + p["slip"]) / 10.0) * 10.0)
    if m.get("panel"):  # drawn last, so the machines without panel modes are unchanged
        p["house_f"] = np.concatenate((r.uniform(250.0, 900.0, 2), p["house_f"]))
        p["house_zeta"] = np.concatenate((r.uniform(0.03, 0.06, 2), p["house_zeta"]))
        p["house_g"] = np.concatenate((r.uniform(0.5, 1.0, 2) * r.choice([-1, 1], 2), p["house_g"]))
    return p


def aux_pair_params(r, zp, zw):
    a = dict(zp=zp, zw=zw, eps=r.uniform(1.4, 1.8))
    for g, z in (("p", zp), ("w", zw)):
        a["pitch_" + g] = r.normal(0, 1.5, z)
        a["slope_" + g] = r.normal(0, 1.2, z)
        a["relief_" + g] = r.uniform(6.0, 12.0)
        a["relief_len_" + g] = r.uniform(0.12, 0.2)
    return a


# ---------------------------------------------------------------------------------------------------------
# signals


def smooth_random(r, t, f_lo, f_hi, n=14):
    """Zero-mean smooth random process: n sinusoids of random frequency (f_lo..f_hi Hz, log-uniform) and phase,
    amplitude ~ 1/f (more slow wander than fast), scaled to unit standard deviation."""
    f = np.exp(r.uniform(np.log(f_lo), np.log(f_hi), n))
    a = 1.0 / np.sqrt(f)
    ph = r.uniform(0, 2 * np.pi, n)
    x = np.zeros_like(t)
    for fi, ai, pi in zip(f, a, ph):
        x += ai * np.sin(2 * np.pi * fi * t + pi)
    return x / x.std()


def tooth_window(u, lo, hi, edge=0.04):
    """Smooth-edged window on the path position u: 1 inside [lo, hi], 0 outside, cosine edges."""
    a = np.clip((u - (lo - edge)) / edge, 0, 1)
    b = np.clip(((hi + edge) - u) / edge, 0, 1)
    return (0.5 - 0.5 * np.cos(np.pi * a)) * (0.5 - 0.5 * np.cos(np.pi * b))


def loaded_te(mpos, load, g, fault=None):
    """Quasi-static loaded transmission error (um) at mesh positions mpos (mesh cycles) under load (relative to
    nominal). g: gear-pair parameters; fault: dict(kind, gear 'p'/'w', tooth 0-based, severity, extra params)."""
    zp, zw, eps = g["zp"], g["zw"], g["eps"]
    k0 = 1.0 / STATIC_DEFLECTION_UM  # unit load per um at one full pair
    base = np.floor(mpos).astype(np.int64)
    ks, es, valid = [], [], []
    for off in (-1, 0, 1):
        k = base + off
        u = (mpos - k - 0.5) / eps
        inside = np.abs(u) <= 0.5
        ip = np.mod(k, zp)
        iw = np.mod(k, zw)
        stiff = k0 * (1.0 - 0.3 * (2 * u) ** 2)
        e = g["pitch_p"][ip] + g["pitch_w"][iw] + g["slope_p"][ip] * u - g["slope_w"][iw] * u
        # tip relief: the wheel's tip meets the pinion root at u = -1/2, the pinion's tip ends the path at +1/2
        lp, lw = g["relief_len_p"], g["relief_len_w"]
        e = e + g["relief_p"] * np.clip((u - (0.5 - lp)) / lp, 0, None) ** 2
        e = e + g["relief_w"] * np.clip(((-0.5 + lw) - u) / lw, 0, None) ** 2
        if fault is not None:
            stiff, e = apply_fault(fault, u, ip, iw, stiff, e)
        ks.append(stiff)
        es.append(e)
        valid.append(inside & (stiff > 0))
    K = np.stack(ks)
    E = np.stack(es)
    V = np.stack(valid)
    W = load  # one full pair (stiffness k0) deflects STATIC_DEFLECTION_UM under the nominal load 1
    d = np.full(mpos.shape, np.inf)
    for _ in range(5):
        act = V & (E < d[None, :])
        ksum = (K * act).sum(0)
        ssum = (K * E * act).sum(0)
        with np.errstate(divide="ignore", invalid="ignore"):
            d_new = (W + ssum) / ksum
        d_new[ksum <= 0] = np.inf
        if np.array_equal(np.isfinite(d_new), np.isfinite(d)) and np.allclose(
            d_new[np.isfinite(d_new)], d[np.isfinite(d)]
        ):
            d = d_new
            break
        d = d_new
    gap = ~np.isfinite(d)
    if gap.any():
        d = free_flight(d, gap)
    return d


def apply_fault(f, u, ip, iw, stiff, e):
    kind, gear, tooth, sev = f["kind"], f["gear"], f["tooth"], f["severity"]
    if kind == "wear":
        # distributed: every tooth of the gear loses material away from the pitch point, tooth by tooth different
        idx = ip if gear == "p" else iw
        depth = f["wear_depth"] * f["wear_factor"][idx]
        # deepest in the gear's own dedendum (sliding is largest there), less on its addendum, none at the pitch
        own = u if gear == "p" else -u  # +1/2 at this gear's tip
        shape = (2 * np.clip(-own, 0, None) + 0.35 * 2 * np.clip(own, 0, None)) ** 1.2
        e = e + depth * shape + f["wear_slope"][idx] * u
        return stiff, e
    if kind == "eccentricity":
        return stiff, e  # handled as a once-per-revolution TE / AM term
    on = (ip == tooth) if gear == "p" else (iw == tooth)
    # the tooth's own tip: +1/2 for the pinion's path, -1/2 for the wheel's
    tip = (u + 0.5) if gear == "p" else (0.5 - u)
    if kind == "crack":
        # root crack: stiffness loss over the tooth's whole contact, largest with the load at its tip (mean = sev)
        loss = sev * (0.5 + tip)
        stiff = np.where(on, stiff * (1.0 - loss), stiff)
    elif kind == "spall":
        w = tooth_window(u, f["spall_lo"], f["spall_hi"])
        e = np.where(on, e + f["spall_depth"] * w, e)
        stiff = np.where(on, stiff * (1.0 - 0.3 * w), stiff)
    elif kind == "broken":
        stiff = np.where(on, 0.0, stiff)
    return stiff, e


def free_flight(d, gap):
    """Where no pair touches, the gears separate: the deflection grows parabolically from its last contact
    value until the next pair catches them (the drop at the end is the impact)."""
    d = d.copy()
    g = gap.astype(np.int8)
    starts = np.flatnonzero(np.diff(np.concatenate(([0], g))) == 1)
    ends = np.flatnonzero(np.diff(np.concatenate((g, [0]))) == -1) + 1
    for s, e_ in zip(starts, ends):
        d0 = d[s - 1] if s > 0 else STATIC_DEFLECTION_UM
        n = e_ - s
        x = (np.arange(n) + 1) / n
        d[s:e_] = d0 + 2.5 * STATIC_DEFLECTION_UM * x**2
    return d


def second_order(freqs, fn, zeta):
    w = 2 * np.pi * freqs
    wn = 2 * np.pi * fn
    return wn**2 / (wn**2 - w**2 + 2j * zeta * wn * w)


def housing(freqs, p):
    """Force -> acceleration: modal sum of the housing resonances (acceleration ~ w^2 below each)."""
    w = 2 * np.pi * freqs
    h = np.zeros(freqs.shape, complex)
    for fn, z, gn in zip(p["house_f"], p["house_zeta"], p["house_g"]):
        wn = 2 * np.pi * fn
        h += gn * (-(w**2)) / (wn**2 - w**2 + 2j * z * wn * w)
    return h


def half_sines(n, fs, times, widths, amps):
    x = np.zeros(n)
    for t0, w, a in zip(times, widths, amps):
        i0 = int(t0 * fs)
        m = max(int(w * fs), 2)
        if i0 + m >= n:
            continue
        x[i0 : i0 + m] += a * np.sin(np.pi * np.arange(m) / m)
    return x


def tacho(phi, t, r, fs):
    """TTL once-per-revolution pulse: rising edge where the input angle crosses an integer, falling at +0.1."""
    tau = 15e-6
    revs = np.arange(np.ceil(phi[0]), np.floor(phi[-1]) + 1)

    def crossing(level):
        return np.interp(level, phi, t) + r.normal(0, 2e-6, level.shape)

    rise = crossing(revs)
    fall = crossing(revs + 0.1)
    v = np.zeros_like(t)
    idx = np.clip(np.searchsorted(rise, t) - 1, 0, len(rise) - 1)
    for shift in (0, 1):
        j = np.clip(idx + shift, 0, len(rise) - 1)
        v += 1.0 / (1.0 + np.exp(-np.clip((t - rise[j]) / tau, -50, 50)))
        v -= 1.0 / (1.0 + np.exp(-np.clip((t - fall[j]) / tau, -50, 50)))
    v = 5.0 * np.clip(v, 0, 1) + r.normal(0, 0.02, t.shape)
    return v


def synthesise(p, fault, seed, ref=None):
    """One recording: returns (accel m/s^2, tacho V, info). ref: the machine's healthy levels (None = this is the
    reference healthy recording: the absolute noise/hum levels are set from it)."""
    r = np.random.default_rng(seed)
    fs, T = p["fs"], p["T"]
    n_file = int(round(fs * T))
    margin = int(0.25 * fs)  # computed and discarded each side: the frequency-domain filters are circular
    N = n_file + 2 * margin
    fso = fs * OVERSAMPLE
    No = N * OVERSAMPLE
    t = np.arange(No) / fso
    # speed: 100 ppm drift + smooth random fluctuation; angle = integral
    drift = 1e-4 * (2 * t / t[-1] - 1) * r.choice([-1, 1]) + 0.3e-4 * smooth_random(r, t, 0.05, 0.3, 4)
    fl = p["speed_fluct"] / 2 * smooth_random(r, t, 0.03, 2.0)
    f_inst = p["f1"] * (1 + drift + fl)
    start = r.uniform(0.1, 0.9)  # revolutions before the first tachometer edge
    phi1 = np.concatenate(([0.0], np.cumsum((f_inst[1:] + f_inst[:-1]) / 2) / fso))
    phi1 = phi1 - phi1[margin * OVERSAMPLE] - start  # the file's first sample is `start` before angle 0
    zp, zw = p["zp"], p["zw"]
    mpos = phi1 * zp
    phi2 = mpos / zw
    load = 1 + p["load_fluct"] / 2 * smooth_random(r, t, 0.1, 5.0)
    # fault parameters
    fd = None
    ecc = {"p": 0.0, "w": 0.0}
    am_extra = {"p": 0.0, "w": 0.0}
    if fault is not None:
        fd = dict(fault)
        gz = zp if fd["gear"] == "p" else zw
        if fd["kind"] == "spall":
            lo = r.uniform(-0.3, 0.05)
            fd["spall_lo"], fd["spall_hi"] = lo, lo + r.uniform(0.15, 0.3)
            fd["spall_depth"] = r.uniform(8.0, 15.0)
        if fd["kind"] == "wear":
            rw = np.random.default_rng(p["seed"] + 7)
            fd["wear_depth"] = rw.uniform(3.0, 6.0)
            fd["wear_factor"] = rw.uniform(0.5, 1.5, gz)
            fd["wear_slope"] = rw.normal(0, 1.0, gz)
        if fd["kind"] == "eccentricity":
            ecc[fd["gear"]] = fd["ecc_um"]
            am_extra[fd["gear"]] = 0.12
    te = loaded_te(mpos, load, p, fd)
    te = te + (p["runout_p"] + ecc["p"]) * np.sin(2 * np.pi * phi1 + p["runout_ph_p"])
    te = te + (p["runout_w"] + ecc["w"]) * np.sin(2 * np.pi * phi2 + p["runout_ph_w"])
    freqs = np.fft.rfftfreq(No, 1 / fso)
    te_f = np.fft.rfft(te - te.mean())
    force = np.fft.irfft(te_f * second_order(freqs, p["mesh_fn"], p["mesh_zeta"]), No)
    am = (
        1
        + (p["am_p"] + am_extra["p"]) * np.sin(2 * np.pi * phi1 + p["am_ph_p"])
        + (p["am_w"] + am_extra["w"]) * np.sin(2 * np.pi * phi2 + p["am_ph_w"])
    )
    force = force * am * load
    # every source reaches the accelerometer through the same housing path (at twice the rate, anti-alias
    # taper, decimation in the frequency domain); the sources' levels are set on the accelerometer, relative to
    # the machine's healthy mesh vibration (the first healthy recording's), so a fault changes only its own part
    hpath = housing(freqs, p)
    taper = np.clip((0.5 * fs - freqs) / (0.08 * fs), 0, 1)
    hpath = hpath * (0.5 - 0.5 * np.cos(np.pi * taper))

    def to_accel(f):
        return np.fft.irfft(np.fft.rfft(f)[: N // 2 + 1] * hpath[: N // 2 + 1] / OVERSAMPLE, N)

    def unit(x):
        return x / max(x.std(), 1e-300)

    y = to_accel(force)
    if ref is None:
        ref = dict(mesh_rms=y.std())
    mesh_rms = ref["mesh_rms"]
    # auxiliary pair on its own belt-driven shaft
    a = p["aux_params"]
    aux_phi = phi1 * p["aux_ratio"] * (1 + 0.003 * smooth_random(r, t, 0.05, 1.0)) + r.uniform()
    aux_te = loaded_te(aux_phi * a["zp"], 1 + 0.05 * smooth_random(r, t, 0.1, 3.0), a)
    aux_f = np.fft.irfft(np.fft.rfft(aux_te - aux_te.mean()) * second_order(freqs, p["mesh_fn"] * 1.3, 0.08), No)
    y += p["aux_gain"] * mesh_rms * unit(to_accel(aux_f))
    # fan tone on the input shaft
    fan = np.zeros(No)
    for h, c in ((1, 1.0), (2, 0.4), (3, 0.15)):
        fan += c * np.sin(2 * np.pi * h * p["fan_blades"] * phi1 + r.uniform(0, 6.3))
    y += p["fan_gain"] * mesh_rms * unit(to_accel(fan))
    # rolling-element broadband, slightly modulated at the cage rate
    bear = r.normal(0, 1, No) * (1 + 0.1 * np.sin(2 * np.pi * p["cage_order"] * phi1))
    y += p["bearing_gain"] * mesh_rms * unit(to_accel(bear))
    # random shocks: the strongest 3-10 times the healthy mesh vibration's rms
    nshock = r.poisson(p["shock_rate"] * T)
    if nshock:
        sh = to_accel(
            half_sines(
                No, fso, r.uniform(0, T, nshock), r.uniform(1e-4, 4e-4, nshock),
                r.uniform(0.3, 1.0, nshock) * r.choice([-1, 1], nshock),
            )
        )
        y += r.uniform(3, 10) * mesh_rms * sh / max(np.abs(sh).max(), 1e-300)
    y = y[margin : margin + n_file]
    f_in = f_inst[margin * OVERSAMPLE : (margin + n_file) * OVERSAMPLE]
    tt = t[margin * OVERSAMPLE : (margin + n_file) * OVERSAMPLE : OVERSAMPLE]
    N = n_file
    if "gain" not in ref:
        ref["gain"] = 4.0 / y.std()  # the machine's healthy level ~ 4 m/s^2 rms before noise and hum
        ref["sig_rms"] = 4.0
    y = y * ref["gain"]
    sig_rms = ref["sig_rms"]
    # mains hum with harmonics, sensor noise: absolute levels of this machine
    hum = np.zeros(N)
    for h, c in ((1, 1.0), (2, 0.5), (3, 0.35), (5, 0.2), (7, 0.1)):
        hum += c * np.sin(2 * np.pi * h * p["hum_hz"] * (1 + 1e-4 * r.normal()) * tt + r.uniform(0, 6.3))
    y = y + p["hum_rel"] * sig_rms / hum.std() * hum
    y = y + r.normal(0, p["noise_rel"] * sig_rms, N)
    tach = tacho(phi1[margin * OVERSAMPLE : (margin + n_file) * OVERSAMPLE : OVERSAMPLE], tt, r, fs)
    info = dict(
        true_mean_speed_hz=float(np.mean(f_in)),
        speed_min_hz=float(f_in.min()),
        speed_max_hz=float(f_in.max()),
        start_revolutions_before_first_edge=float(start),
    )
    if fd is not None and fd["kind"] == "spall":
        info.update(spall_path=[fd["spall_lo"], fd["spall_hi"]], spall_depth_um=fd["spall_depth"])
    if fd is not None and fd["kind"] == "wear":
        info.update(wear_depth_um=fd["wear_depth"])
    return y, tach, info, ref


# ---------------------------------------------------------------------------------------------------------
# files


def write_wav(path, data, fs, fmt, full_scale=None):
    """data: (frames, channels). f32: IEEE float; i16: PCM with per-channel full scales."""
    frames, ch = data.shape
    if fmt == "f32":
        body = data.astype("<f4").tobytes()
        tag, bits = 3, 32
    else:
        q = np.clip(np.round(data / np.asarray(full_scale)[None, :] * 32767), -32768, 32767)
        body = q.astype("<i2").tobytes()
        tag, bits = 1, 16
    block = ch * bits // 8
    hdr = b"RIFF" + struct.pack("<I", 36 + len(body)) + b"WAVE"
    hdr += b"fmt " + struct.pack("<IHHIIHH", 16, tag, ch, int(fs), int(fs) * block, block, bits)
    hdr += b"data" + struct.pack("<I", len(body))
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(hdr)
        f.write(body)
    os.replace(tmp, path)


def write_json(path, obj):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(obj, f, indent=1)
    os.replace(tmp, path)


def sidecar(path, p, frames, seed):
    return {
        "file": os.path.basename(path),
        "scene": p["name"],
        "scene_file": "",
        "sample_rate_hz": p["fs"],
        "frames": frames,
        "duration_s": frames / p["fs"],
        "channels": [
            {"name": "accel", "unit": "m/s^2", "description": "housing accelerometer"},
            {
                "name": "tacho pinion",
                "unit": "pulse",
                "description": "once per input revolution, TTL 0/5 V, rising edge at angle 0",
            },
        ],
        "format": "f32",
        "full_scale": None,
        "clipped_samples": 0,
        "noise_rms": 0.0,
        "seed": seed,
        "speed_change": None,
        "base_hz": p["nominal_rpm"] / 60.0,  # the nameplate speed, what a logger's setup would know
        "period_s": 60.0 / p["nominal_rpm"],
        "evaluation": "holdout generator (tests/holdout/gen_holdout.py)",
        "warnings": [],
    }


def recordings_of(mi, p):
    """(name, fault dict or None, seed) for one machine: three healthy, then the faults."""
    r = np.random.default_rng(p["seed"] + 1)
    out = [("healthy-s%d" % (i + 1), None, p["seed"] * 10 + i + 1) for i in range(3)]
    for j, (kind, sev, which) in enumerate(FAULTS):
        gear = ("p" if which == "A" else "w") if mi % 2 == 0 else ("w" if which == "A" else "p")
        z = p["zp"] if gear == "p" else p["zw"]
        tooth = int(r.integers(0, z))
        f = dict(kind=kind, gear=gear, tooth=tooth, severity=sev)
        if kind == "eccentricity":
            f["ecc_um"] = float(r.uniform(12.0, 25.0))
        label = kind if kind != "crack" else "crack%d" % round(sev * 100)
        gname = "pinion" if gear == "p" else "wheel"
        out.append(("%s-%s" % (label, gname), f, p["seed"] * 10 + 50 + j))
    return out


def generate_machine(mi, m, outdir, quick=False):
    p = machine_params(m)
    if quick:
        p["T"] = min(p["T"], 6.0)
    d = os.path.join(outdir, m["name"])
    os.makedirs(d, exist_ok=True)
    ref = None
    for name, f, seed in recordings_of(mi, p):
        t0 = time.time()
        y, tach, info, ref = synthesise(p, f, seed, ref)
        data = np.stack([y, tach], 1)
        path = os.path.join(d, name + ".wav")
        clipped = 0
        if m["fmt"] == "f32":
            write_wav(path, data, p["fs"], "f32")
            write_json(path + ".json", sidecar(path, p, len(y), seed))
        else:
            fsc = [20.0 * ref["sig_rms"], 6.0]
            clipped = int((np.abs(y) >= fsc[0]).sum())
            write_wav(path, data, p["fs"], "i16", fsc)
        truth = dict(
            file=path,
            machine=m["name"],
            zp=p["zp"],
            zw=p["zw"],
            fs=p["fs"],
            format=m["fmt"],
            sidecar=m["fmt"] == "f32",
            int16_full_scale=(20.0 * ref["sig_rms"]) if m["fmt"] == "i16" else None,
            clipped_samples=clipped,
            nominal_rpm=p["nominal_rpm"],
            nominal_speed_hz=p["nominal_rpm"] / 60.0,
            speed_fluctuation=p["speed_fluct"],
            load_fluctuation=p["load_fluct"],
            contact_ratio=p["eps"],
            noise_rel=p["noise_rel"],
            fault=None if f is None else f["kind"],
            severity=None if f is None else f["severity"],
            gear=None if f is None else ("pinion" if f["gear"] == "p" else "wheel"),
            tooth=None if (f is None or f["kind"] in ("wear", "eccentricity")) else f["tooth"] + 1,
            ecc_um=None if f is None else f.get("ecc_um"),
            seed=seed,
            aux_mesh_hz=p["aux_ratio"] * info["true_mean_speed_hz"] * p["aux_zp"],
            aux_teeth=[p["aux_zp"], p["aux_zw"]],
            fan_blades=p["fan_blades"],
            hum_hz=p["hum_hz"],
            mesh_resonance_hz=p["mesh_fn"],
            housing_resonances_hz=[float(x) for x in p["house_f"]],
            healthy_rms=ref["sig_rms"],
            rms=float(y.std()),
            **info,
        )
        write_json(os.path.join(d, name + ".truth.json"), truth)
        print(
            "%s/%s: %.1f s, rms %.2f, speed %.3f Hz (nominal %.0f rpm) [%.1f s]"
            % (m["name"], name, p["T"], y.std(), info["true_mean_speed_hz"], p["nominal_rpm"], time.time() - t0),
            flush=True,
        )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="/tmp/holdout")
    ap.add_argument("--machines", default=None, help="comma-separated machine names or indices (1-based)")
    ap.add_argument("--quick", action="store_true", help="6 s recordings (a smoke test)")
    ap.add_argument("--fresh", action="store_true", help="the fresh set (m10-m14) instead of m1-m9")
    ap.add_argument("--common", action="store_true", help="the common-factor set (m15-m18) instead of m1-m9")
    a = ap.parse_args()
    machines = COMMON_MACHINES if a.common else FRESH_MACHINES if a.fresh else MACHINES
    sel = list(range(len(machines)))
    if a.machines:
        want = a.machines.split(",")
        sel = [i for i, m in enumerate(machines) if m["name"] in want or str(i + 1) in want or m["name"].split("-")[0] in want]
    for i in sel:
        generate_machine(i, machines[i], a.out, a.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
