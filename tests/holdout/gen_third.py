#!/usr/bin/env python3
"""Third, independent gearbox generator: a 10-DOF lumped dynamic model integrated in the time domain
(numpy + scipy only; no gearvib code, nothing copied from tests/common/gearbox_gen.rs or gen_holdout.py).

Physics (what is NOT in the other two generators):

1. Structure, 10 DOF: pinion torsion (theta_p, tied to the motor by a shaft of stiffness k_tp; the motor's
   angle is the prescribed kinematic rotation, so theta_p is the vibratory angle), wheel torsion theta_w,
   a load inertia theta_L (shaft k_tw to the wheel, load torque T_L(t) applied on it), pinion and wheel
   centres x/y on bearings (k_b, to the housing), a housing mass x_h/y_h on mounts (low modes 150-600 Hz),
   and a sensor panel (one DOF along the accelerometer's radial direction n_s, 1.2-4.5 kHz) on the housing.
   The accelerometer reads the panel's absolute acceleration. Damping: modal (3-6 %) from the structure
   alone, plus a mesh damper along the line of action that acts only while some tooth pair is in contact.
2. Mesh: one line of action (unit vector n at the pressure angle); its compression is
   delta = r_bp theta_p + r_bw theta_w + n.(u_p - u_w). Each tooth pair i (pair k meets pinion tooth k mod zp
   and wheel tooth k mod zw, centred on mesh position k + 1/2, in contact over the contact ratio eps,
   1.3-1.8) pushes F_i = k_i(u) max(delta - e_i(u), 0): unilateral contact, so contact loss, separation and
   re-impact come out of the dynamics. k_i(u) is a series stiffness of the two teeth and a Hertz term; each
   tooth's compliance follows a cantilever (Weber-like) law in its load height h: c = A_b h^3 + A_s h + A_f
   (thin small-z teeth more compliant), so the pair stiffness peaks near the pitch point and drops 25-35 % at
   the ends. e_i(u) = pitch errors (cumulative once-per-rev + random) + profile slope and form errors + tip
   relief + fault terms + the once-per-rev centre run-out of both gears projected on n.
3. Integration: Newmark-beta average acceleration (beta 1/4, gamma 1/2), fixed step, linear-implicit in the
   contact (the active set and k_i at t_{n+1} from the Newmark predictor), the time-varying rank-one mesh term
   by Sherman-Morrison; 4-8x the output rate (2x at 96 kHz: 192 kHz), 0.3 s pre-roll discarded, then an FIR
   anti-alias decimation (scipy.signal.resample_poly). All recordings of a machine are integrated as one batch.
4. Faults (physics): crack = extra root-rotation compliance kappa(q) h^2 of one tooth, kappa = 5 q^1.5/(1-q)^1.5
   for the depth fraction q (10/25/50 %: pair stiffness at the tooth tip -7/-29/-68 %); spall = a pit over
   15-30 % of the path near the pitch line, a profile dip (5-12 um x its face-width share) and a stiffness loss
   (60 % of its face-width share, 50-90 %); broken = the tooth is gone (its pair carries nothing: the gears
   separate under the load and re-impact on the next pair); wear = every tooth of the gear loses material in
   proportion to the sliding distance from the pitch point (deepest 4-8 um, dedendum 1.0, addendum 0.6,
   tooth-to-tooth 0.7-1.3); eccentricity = the gear's centre displaced 15-40 um, rotating with the gear
   (its projection on n a once-per-rev TE, its mass unbalance a rotating force on the bearings).
5. Operating conditions: speed = nominal x (1 + ~100 ppm drift over the record + 0.5-2 % peak smooth
   fluctuation 0.05-3 Hz); load torque fluctuation 3-8 % (0.1-8 Hz); the motor slip puts the nameplate 1-3 %
   above the true mean speed (rounded to 10 rpm). Rolling-element noise forces on both bearings (white,
   modulated 40 % at each shaft's cage rate, 0.4 x shaft) go through the dynamics.
6. Sensor chain: slowly varying gain (+-5 %, 0.02-0.3 Hz), DC offset (one machine: a DC-coupled MEMS sensor
   with a gravity component of several m/s^2), pink noise band-limited 3 Hz - 0.45 fs at 0.3-0.7 of the
   healthy RMS (absolute per machine), mains hum 50/60 Hz with harmonics 2,3,5,7, electrical glitches
   (Poisson 0.3-2 /s, 1 or 3 samples, 4-15 x RMS).
7. Channel 2: a once-per-input-revolution optical/PNP sensor: low level 0.3 V, high 10-12 V (12 V supply),
   high for 3 % of a revolution, RC rising edge (tau 8 us) and faster fall, 15 mV noise. Angle 0 of the input
   shaft is the rising edge's mid-level crossing (the edge gearvib reads). Tooth numbering as gen_holdout.py:
   tooth n of a gear is centred (n - 1/2)/z of a revolution after its origin; the input origin at the
   rising edge, the wheel's origin its angle at the first rising edge in the file (both 0 there).

Output: /tmp/third/mNN-zAzB/NAME.wav (ch1 accel m/s^2, ch2 tacho V) + NAME.truth.json (+ NAME.wav.json
sidecar for float32 machines); m21 24-bit PCM, m23 16-bit PCM, both without sidecar.

Usage: gen_third.py [--out /tmp/third] [--machines m20,m22] [--quick]
"""

import argparse
import json
import os
import struct
import sys
import time

import numpy as np
from scipy.signal import resample_poly, sosfilt, butter

MACHINES = [
    dict(name="m20-z19z41", zp=19, zw=41, fs=25600.0, f1=23.7, T=12.0, fmt="f32", seed=2020, ovs=4, module=4.0),
    dict(name="m21-z13z43", zp=13, zw=43, fs=48000.0, f1=41.5, T=10.0, fmt="i24", seed=2121, ovs=4, module=5.0),
    dict(name="m22-z22z67", zp=22, zw=67, fs=12800.0, f1=9.3, T=15.0, fmt="f32", seed=2222, ovs=8, module=5.0,
         mems=True),
    dict(name="m23-z29z31", zp=29, zw=31, fs=25600.0, f1=31.0, T=12.0, fmt="i16", seed=2323, ovs=4, module=3.0),
    dict(name="m24-z25z50", zp=25, zw=50, fs=96000.0, f1=47.5, T=10.0, fmt="f32", seed=2424, ovs=2, module=3.0),
]

FAULTS = [  # (kind, severity, which gear: A / B alternate with the machine index)
    ("crack", 0.10, "A"),
    ("crack", 0.25, "B"),
    ("crack", 0.50, "A"),
    ("spall", 1.0, "p"),
    ("spall", 1.0, "w"),
    ("broken", 1.0, "B"),
    ("wear", 1.0, "A"),
    ("eccentricity", 1.0, "B"),
]

PREROLL = 0.3  # s integrated and discarded
RHO = 7850.0
E_PAIR = 14e9  # N/m per m of face width, one tooth pair near the pitch point (ISO 6336 c' ~ 14 N/mm/um)


# ------------------------------------------------------------------------------------------------------
def smooth_random(r, t, f_lo, f_hi, n=12):
    f = np.exp(r.uniform(np.log(f_lo), np.log(f_hi), n))
    a = 1.0 / np.sqrt(f)
    ph = r.uniform(0, 2 * np.pi, n)
    x = np.zeros_like(t)
    for fi, ai, pi in zip(f, a, ph):
        x += ai * np.sin(2 * np.pi * fi * t + pi)
    return x / x.std()


def machine_params(m):
    r = np.random.default_rng(m["seed"])
    p = dict(m)
    zp, zw = m["zp"], m["zw"]
    mod = m["module"] * 1e-3
    alpha = np.deg2rad(20.0)
    p["eps"] = r.uniform(1.3, 1.8)
    b = r.uniform(0.025, 0.045)  # face width (m)
    p["face"] = b
    rp, rw = mod * zp / 2, mod * zw / 2
    p["rbp"], p["rbw"] = rp * np.cos(alpha), rw * np.cos(alpha)
    # gear bodies as discs with a bore (70 % of solid mass); shaft lengths add to lateral mass
    mp_ = 0.7 * RHO * np.pi * rp**2 * b + 1.5
    mw_ = 0.7 * RHO * np.pi * rw**2 * b + 3.0
    p["mp"], p["mw"] = mp_, mw_
    p["Jp"], p["Jw"] = 0.5 * mp_ * rp**2, 0.5 * mw_ * rw**2
    p["JL"] = p["Jw"] * r.uniform(3, 8)
    # tooth compliance law (normalised): c(h) = A_b h^3 + A_s h + A_f; small z teeth more compliant
    for g, z in (("p", zp), ("w", zw)):
        p["Ab_" + g] = 1.0 * (1 + 6.0 / z)
        p["As_" + g] = 0.35
        p["Af_" + g] = 0.25
    p["cH"] = 0.4
    # scale: one pair at the pitch point has stiffness E_PAIR * b
    hmid = 0.575
    cmid = sum(p["Ab_" + g] * hmid**3 + p["As_" + g] * hmid + p["Af_" + g] for g in "pw") + p["cH"]
    p["k_unit"] = E_PAIR * b * cmid  # k_pair = k_unit / c_total
    # shafts and bearings
    p["ktp"] = r.uniform(2e4, 6e4) * (rp / 0.04) ** 4 * 10  # N m/rad (pinion shaft to motor)
    p["ktw"] = r.uniform(4e4, 1.2e5) * (rw / 0.08) ** 2 * 10
    p["kb"] = r.uniform(2e8, 6e8)
    p["mh"] = r.uniform(25.0, 60.0)
    p["kh"] = (2 * np.pi * r.uniform(150, 600)) ** 2 * p["mh"]
    p["khy"] = p["kh"] * r.uniform(0.6, 1.6)
    p["ms"] = r.uniform(0.15, 0.5)
    fpanel = r.uniform(1200.0, min(4500.0, 0.35 * m["fs"]))
    p["panel_hz"] = fpanel
    p["ks"] = (2 * np.pi * fpanel) ** 2 * p["ms"]
    p["sensor_dir"] = r.uniform(0, np.pi)
    p["loa_dir"] = np.pi / 2 - alpha + r.uniform(-0.05, 0.05)
    p["zeta"] = r.uniform(0.03, 0.06)
    p["zeta_mesh"] = r.uniform(0.04, 0.08)
    # tooth errors (um), fixed for the machine
    for g, z in (("p", zp), ("w", zw)):
        ang = (np.arange(z) + 0.5) / z
        p["pitch_" + g] = r.uniform(1.5, 4.0) * np.sin(2 * np.pi * ang + r.uniform(0, 2 * np.pi)) + r.normal(
            0, r.uniform(0.5, 1.2), z)
        p["slope_" + g] = r.normal(0, r.uniform(0.6, 1.5), z)
        p["form_" + g] = r.normal(0, 0.8, 3)  # common profile form error: Legendre P2..P4 coefficients (um)
        p["relief_" + g] = r.uniform(5.0, 12.0)
        p["relief_len_" + g] = r.uniform(0.15, 0.25)
        p["runout_" + g] = r.uniform(1.5, 5.0)
        p["runout_ph_" + g] = r.uniform(0, 2 * np.pi)
    p["static_um"] = r.uniform(10.0, 15.0)  # mean deflection of one full pair under the nominal load
    p["load_fluct"] = r.uniform(0.03, 0.08)
    p["speed_fluct"] = r.uniform(0.005, 0.02)
    p["slip"] = r.uniform(0.01, 0.03)
    p["nominal_rpm"] = float(round(m["f1"] * 60.0 * (1 + p["slip"]) / 10.0) * 10.0)
    p["bearing_rel"] = r.uniform(0.005, 0.015)  # rolling-noise force rms / mean mesh force (at 100 kHz)
    p["cage_p"], p["cage_w"] = r.uniform(0.38, 0.43), r.uniform(0.38, 0.43)
    p["hum_hz"] = float(r.choice([50.0, 60.0]))
    p["hum_rel"] = r.uniform(0.04, 0.15)
    p["noise_rel"] = r.uniform(0.3, 0.7)
    p["gain_var"] = 0.05
    p["spike_rate"] = r.uniform(0.3, 2.0)
    p["dc"] = (9.81 * np.cos(r.uniform(0.3, 1.2))) if m.get("mems") else r.uniform(-0.05, 0.05)
    p["tacho_hi"] = r.uniform(10.0, 12.0)
    return p


# ------------------------------------------------------------------------------------------------------
def structure(p):
    """Mass, structural stiffness and damping matrices, line-of-action vector g, sensor vector."""
    n = 10
    M = np.diag([p["Jp"], p["Jw"], p["JL"], p["mp"], p["mp"], p["mw"], p["mw"], p["mh"], p["mh"], p["ms"]])
    K = np.zeros((n, n))

    def spring(i, j, k, di=1.0, dj=1.0):
        # k (di x_i - dj x_j)^2 / 2 ; j = None: to ground
        if j is None:
            K[i, i] += k * di * di
            return
        K[i, i] += k * di * di
        K[j, j] += k * dj * dj
        K[i, j] -= k * di * dj
        K[j, i] -= k * di * dj

    spring(0, None, p["ktp"])
    spring(1, 2, p["ktw"])
    for c, h in ((3, 7), (4, 8), (5, 7), (6, 8)):
        spring(c, h, p["kb"])
    spring(7, None, p["kh"])
    spring(8, None, p["khy"])
    cs, sn = np.cos(p["sensor_dir"]), np.sin(p["sensor_dir"])
    # panel: k_s (z_s - cs x_h - sn y_h)^2 / 2
    v = np.zeros(n)
    v[9], v[7], v[8] = 1.0, -cs, -sn
    K += p["ks"] * np.outer(v, v)
    nx, ny = np.cos(p["loa_dir"]), np.sin(p["loa_dir"])
    g = np.array([p["rbp"], p["rbw"], 0, nx, ny, -nx, -ny, 0, 0, 0])
    # modal damping of the structure with the mean mesh (so every mode gets its zeta), minus the mesh's share,
    # which is added back as the contact-gated mesh damper
    kmean = p["k_unit"] / 1.75 * p["eps"] * 0.9
    Kt = K + kmean * np.outer(g, g)
    w2, phi = np.linalg.eigh(np.linalg.solve(np.sqrt(M), np.linalg.solve(np.sqrt(M), Kt).T).T)
    Ms = np.sqrt(M)
    modes = np.linalg.solve(Ms, phi)  # mass-normalised
    wn = np.sqrt(np.maximum(w2, 0))
    C = M @ modes @ np.diag(2 * p["zeta"] * wn) @ modes.T @ M
    me = 1.0 / (p["rbp"] ** 2 / p["Jp"] + p["rbw"] ** 2 / p["Jw"])
    cm = 2 * p["zeta_mesh"] * np.sqrt(kmean * me)
    return M, K, C, g, cm, kmean, wn / (2 * np.pi), modes


def pair_arrays(mpos, p, fault, runout_te, deps=0.0):
    """Per step and candidate pair (3 slots): stiffness k_i (N/m) and separation e_i (m)."""
    zp, zw, eps = p["zp"], p["zw"], p["eps"]
    base = np.floor(mpos).astype(np.int64)
    Ks, Es = [], []
    for off in (-1, 0, 1):
        k = base + off
        u = (mpos - k - 0.5) / (eps + deps)
        inside = np.abs(u) <= 0.5
        ip, iw = np.mod(k, zp), np.mod(k, zw)
        hp = 0.15 + 0.85 * (u + 0.5)  # load height on the pinion tooth (root -> tip along the path)
        hw = 0.15 + 0.85 * (0.5 - u)
        cp = p["Ab_p"] * hp**3 + p["As_p"] * hp + p["Af_p"]
        cw = p["Ab_w"] * hw**3 + p["As_w"] * hw + p["Af_w"]
        e = p["pitch_p"][ip] + p["pitch_w"][iw] + (p["slope_p"][ip] - p["slope_w"][iw]) * u
        x2 = 2 * u
        for g, sgn in (("p", 1), ("w", -1)):
            a2, a3, a4 = p["form_" + g]
            xs = sgn * x2
            e = e + a2 * 0.5 * (3 * xs**2 - 1) + a3 * 0.5 * (5 * xs**3 - 3 * xs) + a4 * (35 * xs**4 - 30 * xs**2 + 3) / 8
        lp, lw = p["relief_len_p"], p["relief_len_w"]
        e = e + p["relief_p"] * np.clip((u - (0.5 - lp)) / lp, 0, None) ** 2
        e = e + p["relief_w"] * np.clip(((-0.5 + lw) - u) / lw, 0, None) ** 2
        extra_c = np.zeros_like(u)
        kscale = np.ones_like(u)
        if fault is not None:
            kind, gear, tooth = fault["kind"], fault["gear"], fault["tooth"]
            on = (ip == tooth) if gear == "p" else (iw == tooth)
            h = hp if gear == "p" else hw
            if kind == "crack":
                q = fault["severity"]
                kap = 5.0 * q**1.5 / (1 - q) ** 1.5
                extra_c = np.where(on, kap * p["Ab_" + gear] * h**2, 0.0)
            elif kind == "spall":
                lo, hi, fw, d = fault["spall_lo"], fault["spall_hi"], fault["spall_fw"], fault["spall_depth"]
                own = u if gear == "p" else -u
                ww = np.clip((own - lo) / 0.03, 0, 1) * np.clip((hi - own) / 0.03, 0, 1)
                ww = np.where(on, ww, 0.0)
                e = e + d * fw * ww
                kscale = kscale * (1 - 0.6 * fw * ww)
            elif kind == "broken":
                kscale = np.where(on, 0.0, kscale)
            elif kind == "wear":
                idx = ip if gear == "p" else iw
                own = u if gear == "p" else -u  # +1/2 at this gear's tip
                s = own - fault["pitch_u"]
                shape = np.where(s < 0, -s, 0.6 * s) / (0.5 + abs(fault["pitch_u"]))
                e = e + fault["wear_depth"] * fault["wear_factor"][idx] * shape
        ctot = cp + cw + p["cH"] + extra_c
        kk = p["k_unit"] / ctot * kscale
        kk = np.where(inside, kk, 0.0)
        e = e * 1e-6 + runout_te
        e = np.where(inside, e, 1.0)  # out of the path: never in contact
        Ks.append(kk)
        Es.append(e)
    return np.stack(Ks, 1), np.stack(Es, 1)


# ------------------------------------------------------------------------------------------------------
def recordings_of(mi, p):
    r = np.random.default_rng(p["seed"] + 1)
    out = [("healthy-s%d" % (i + 1), None, p["seed"] * 10 + i + 1) for i in range(3)]
    for j, (kind, sev, which) in enumerate(FAULTS):
        if which in ("A", "B"):
            gear = ("p" if which == "A" else "w") if mi % 2 == 0 else ("w" if which == "A" else "p")
        else:
            gear = which
        z = p["zp"] if gear == "p" else p["zw"]
        tooth = int(r.integers(0, z))
        f = dict(kind=kind, gear=gear, tooth=tooth, severity=sev)
        if kind == "spall":
            lo = r.uniform(-0.25, 0.0)
            f.update(spall_lo=lo, spall_hi=lo + r.uniform(0.15, 0.3), spall_fw=r.uniform(0.5, 0.9),
                     spall_depth=r.uniform(5.0, 12.0))
        if kind == "wear":
            f.update(wear_depth=r.uniform(4.0, 8.0), wear_factor=r.uniform(0.7, 1.3, z), pitch_u=r.uniform(-0.08, 0.08))
        if kind == "eccentricity":
            f["ecc_um"] = float(r.uniform(40.0, 100.0))
            f["ecc_ph"] = float(r.uniform(0, 2 * np.pi))
        label = kind if kind != "crack" else "crack%d" % round(sev * 100)
        out.append(("%s-%s" % (label, "pinion" if gear == "p" else "wheel"), f, p["seed"] * 10 + 50 + j))
    return out


def kinematics(p, seed, fsi, Ni, n0):
    """Input angle (revolutions, 0 at the first tacho edge after the file start), speed and load at the
    integration rate; n0 = first integration sample of the file (after the pre-roll)."""
    r = np.random.default_rng(seed)
    t = np.arange(Ni) / fsi
    T = t[-1]
    drift = 1e-4 * r.choice([-1, 1]) * (t / T - 0.5) * 2 * 0.5 + 2e-5 * smooth_random(r, t, 0.05, 0.3, 4)
    fl = smooth_random(r, t, 0.05, 3.0)
    fl = p["speed_fluct"] * fl / np.abs(fl).max()
    f_inst = p["f1"] * (1 + drift + fl)
    phi = np.concatenate(([0.0], np.cumsum((f_inst[1:] + f_inst[:-1]) / 2) / fsi))
    start = r.uniform(0.1, 0.9)
    phi = phi - phi[n0] - start
    ld = smooth_random(r, t, 0.1, 8.0)
    load = 1 + p["load_fluct"] * ld / np.abs(ld).max()
    return t, phi, f_inst, load, r, start


def simulate_machine(p, recs, quick=False):
    fs = p["fs"]
    ovs = p["ovs"]
    fsi = fs * ovs
    dt = 1.0 / fsi
    T = p["T"] if not quick else min(p["T"], 4.0)
    n_file = int(round(fs * T))
    n0 = int(round(PREROLL * fsi))
    Ni = n0 + n_file * ovs + 64 * ovs
    B = len(recs)
    M, Ks, Cs, g, cm, kmean, fn, modes = structure(p)
    zp, zw = p["zp"], p["zw"]
    F0 = kmean * p["static_um"] * 1e-6 / (p["eps"] * 0.9) * p["eps"] * 0.9  # mean mesh force: one full pair's
    F0 = p["k_unit"] / 1.68 * p["static_um"] * 1e-6  # deflection static_um under the nominal load
    TL0 = F0 * p["rbw"]
    beta, gamma = 0.25, 0.5
    S0 = M + gamma * dt * Cs + beta * dt**2 * Ks
    P = np.linalg.inv(S0)
    w = P @ g
    s = g @ w
    kin = []
    for name, f, seed in recs:
        t, phi, f_inst, load, r, start = kinematics(p, seed, fsi, Ni, n0)
        kin.append((phi, f_inst, load, r, start))
    # per-recording constant excitation pieces
    state_x = np.zeros((B, 10))
    state_v = np.zeros((B, 10))
    state_a = np.zeros((B, 10))
    out = np.zeros((B, Ni))
    chunk = 200000
    rb = [np.random.default_rng(seed + 99) for (_, _, seed) in recs]
    cs_, sn_ = np.cos(p["loa_dir"]), np.sin(p["loa_dir"])
    for c0 in range(0, Ni, chunk):
        c1 = min(Ni, c0 + chunk)
        nc = c1 - c0
        KK = np.zeros((nc, B, 3))
        EE = np.zeros((nc, B, 3))
        FF = np.zeros((nc, B, 10))
        for b, (name, f, seed) in enumerate(recs):
            phi, f_inst, load, r, start = kin[b]
            ph = phi[c0:c1]
            ph2 = ph * zp / zw
            ecc = {"p": 0.0, "w": 0.0}
            eph = {"p": 0.0, "w": 0.0}
            if f is not None and f["kind"] == "eccentricity":
                ecc[f["gear"]] = f["ecc_um"]
                eph[f["gear"]] = f["ecc_ph"]
            # centre run-out of each gear (healthy + fault), as a vector rotating with the gear; its projection
            # on the line of action enters the separation (pinion displaced along +n compresses: e decreases)
            te = np.zeros(nc)
            da = np.zeros(nc)
            cdir = p["loa_dir"] + np.pi / 2 - np.deg2rad(20.0)  # line of centres
            for gg, ang, sgn in (("p", ph, -1.0), ("w", ph2, 1.0)):
                a_h = p["runout_" + gg] * np.exp(1j * p["runout_ph_" + gg])
                a_f = ecc[gg] * np.exp(1j * eph[gg])
                rot = np.exp(1j * 2 * np.pi * ang) * (a_h + a_f)
                te += sgn * 1e-6 * (rot.real * cs_ + rot.imag * sn_)
                da += sgn * 1e-6 * (rot.real * np.cos(cdir) + rot.imag * np.sin(cdir))
                if ecc[gg] > 0:  # mass unbalance of the eccentric gear
                    mg = p["mp"] if gg == "p" else p["mw"]
                    om = 2 * np.pi * f_inst[c0:c1] * (1 if gg == "p" else zp / zw)
                    fu = mg * ecc[gg] * 1e-6 * om**2 * np.exp(1j * (2 * np.pi * ang + eph[gg]))
                    ix = 3 if gg == "p" else 5
                    FF[:, b, ix] += fu.real
                    FF[:, b, ix + 1] += fu.imag
            # a displaced centre also moves the contact along the path (the mesh position shifts by the
            # LOA component over the base pitch) and changes the centre distance, hence the contact ratio
            pb = np.pi * p["module"] * 1e-3 * np.cos(np.deg2rad(20.0))
            deps = -da / (np.sin(np.deg2rad(20.0)) * pb)
            K_, E_ = pair_arrays(ph * zp - te / pb, p, f, te, deps)
            KK[:, b, :] = K_
            EE[:, b, :] = E_
            FF[:, b, 2] += TL0 * load[c0:c1]
            # rolling-element noise on both bearings, modulated at the cage rates
            sig = p["bearing_rel"] * F0 * np.sqrt(fsi / 1e5)
            mod_p = 1 + 0.4 * np.sin(2 * np.pi * p["cage_p"] * ph)
            mod_w = 1 + 0.4 * np.sin(2 * np.pi * p["cage_w"] * ph2)
            nz = rb[b].normal(0, sig, (nc, 4))
            FF[:, b, 3] += nz[:, 0] * mod_p
            FF[:, b, 4] += nz[:, 1] * mod_p
            FF[:, b, 5] += nz[:, 2] * mod_w
            FF[:, b, 6] += nz[:, 3] * mod_w
        if c0 == 0:
            # static equilibrium with the pairs touching at step 0
            for b in range(B):
                act = KK[0, b] > 0
                ke = KK[0, b][act].sum()
                se = (KK[0, b] * EE[0, b])[act].sum()
                if ke < 0.5 * kmean:  # only a broken tooth's pair at step 0: start from the mean mesh
                    ke, se = kmean, 0.0
                x0 = np.linalg.solve(Ks + ke * np.outer(g, g), FF[0, b] + g * se)
                state_x[b] = x0
        x, v, a = state_x, state_v, state_a
        c1b, c2b = dt * dt * (0.5 - beta), dt * (1 - gamma)
        bd2, gd = beta * dt * dt, gamma * dt
        KsT, CsT, PT = Ks.T.copy(), Cs.T.copy(), P.T.copy()
        acc_out = out
        for n in range(nc):
            xt = x + dt * v + c1b * a
            vt = v + c2b * a
            dl = xt @ g
            dv = vt @ g
            Kc = KK[n]
            Ec = EE[n]
            act = dl[:, None] > Ec
            Ka = Kc * act
            ke = Ka.sum(1)
            se = (Ka * Ec).sum(1)
            gate = cm * (ke > 0)
            fm = ke * dl - se + gate * dv
            rr = FF[n] - vt @ CsT - xt @ KsT - fm[:, None] * g
            y = rr @ PT
            q = gd * gate + bd2 * ke
            a = y - ((q / (1 + q * s)) * (y @ g))[:, None] * w
            x = xt + bd2 * a
            v = vt + gd * a
            acc_out[:, c0 + n] = a[:, 9]
        state_x, state_v, state_a = x, v, a
    res = []
    for b in range(B):
        phi, f_inst, load, r, start = kin[b]
        acc = out[b, n0:]
        # FIR anti-alias decimation (Kaiser window, resample_poly)
        acc = resample_poly(acc, 1, ovs)[:n_file]
        phi_o = phi[n0:n0 + n_file * ovs:ovs]
        fin = f_inst[n0:n0 + n_file * ovs]
        res.append(dict(acc=acc, phi=phi_o, f_in=fin, r=r, start=start, load=load[n0:n0 + n_file * ovs]))
    return res, fn


def pink_noise(r, n, fs, lo=3.0):
    X = np.fft.rfft(r.normal(0, 1, n))
    f = np.fft.rfftfreq(n, 1 / fs)
    h = np.where(f > lo, 1 / np.sqrt(np.maximum(f, lo)), 0.0) * (f < 0.45 * fs)
    x = np.fft.irfft(X * h, n)
    return x / x.std()


def tacho(phi, fs, r, hi):
    """Once per input revolution: 0.3 V low, `hi` V high for 3 % of a revolution; RC rise (tau 8 us), fall 3 us.
    The rising edge's mid-level crossing is at the integer input angles."""
    n = len(phi)
    t = np.arange(n) / fs
    lo = 0.3
    revs = np.arange(np.ceil(phi[0]), np.floor(phi[-1]) + 1)
    tr = np.interp(revs, phi, t) + r.normal(0, 1e-6, revs.shape)
    tf = np.interp(revs + 0.03, phi, t)
    tau_r, tau_f = 8e-6, 3e-6
    onset = tr - tau_r * np.log(2.0)  # the RC edge starts earlier so that its mid level is crossed at tr
    v = np.full(n, lo)
    for a, e in zip(onset, tf):
        i0 = max(int(np.floor(a * fs)) - 1, 0)
        i1 = min(int(np.ceil((e + 20 * tau_f) * fs)) + 2, n)
        if i1 <= i0:
            continue
        tt = t[i0:i1]
        rise = np.where(tt > a, 1 - np.exp(-(tt - a) / tau_r), 0.0)
        fall = np.where(tt > e, np.exp(-(tt - e) / tau_f), 1.0)
        level = rise * fall
        # the fall starts from the level reached
        v[i0:i1] = np.maximum(v[i0:i1], lo + (hi - lo) * level)
    return v + r.normal(0, 0.015, n)


def write_wav(path, data, fs, fmt, full_scale=None):
    frames, ch = data.shape
    if fmt == "f32":
        body = data.astype("<f4").tobytes()
        tag, bits = 3, 32
    elif fmt == "i16":
        q = np.clip(np.round(data / np.asarray(full_scale)[None, :] * 32767), -32768, 32767)
        body = q.astype("<i2").tobytes()
        tag, bits = 1, 16
    else:  # i24
        q = np.clip(np.round(data / np.asarray(full_scale)[None, :] * 8388607), -8388608, 8388607).astype("<i4")
        b4 = q.reshape(-1).view(np.uint8).reshape(-1, 4)
        body = b4[:, :3].tobytes()
        tag, bits = 1, 24
    block = ch * bits // 8
    hdr = b"RIFF" + struct.pack("<I", 36 + len(body)) + b"WAVE"
    hdr += b"fmt " + struct.pack("<IHHIIHH", 16, tag, ch, int(fs), int(fs) * block, block, bits)
    hdr += b"data" + struct.pack("<I", len(body))
    with open(path + ".tmp", "wb") as f:
        f.write(hdr)
        f.write(body)
    os.replace(path + ".tmp", path)


def write_json(path, obj):
    with open(path + ".tmp", "w") as f:
        json.dump(obj, f, indent=1)
    os.replace(path + ".tmp", path)


def sidecar(path, p, frames, seed):
    return {
        "file": os.path.basename(path),
        "scene": p["name"],
        "scene_file": "",
        "sample_rate_hz": p["fs"],
        "frames": frames,
        "duration_s": frames / p["fs"],
        "channels": [
            {"name": "accel", "unit": "m/s^2", "description": "housing panel accelerometer, radial"},
            {"name": "tacho pinion", "unit": "pulse",
             "description": "once per input revolution, optical PNP 0.3/%.1f V, high 3 %% of a rev, rising edge at angle 0" % p["tacho_hi"]},
        ],
        "format": "f32",
        "full_scale": None,
        "clipped_samples": 0,
        "noise_rms": 0.0,
        "seed": seed,
        "speed_change": None,
        "base_hz": p["nominal_rpm"] / 60.0,
        "period_s": 60.0 / p["nominal_rpm"],
        "evaluation": "third generator (tests/holdout/gen_third.py, 10-DOF Newmark)",
        "warnings": [],
    }


def generate_machine(mi, m, outdir, quick=False):
    p = machine_params(m)
    if quick:
        p["T"] = min(p["T"], 4.0)
    d = os.path.join(outdir, m["name"])
    os.makedirs(d, exist_ok=True)
    recs = recordings_of(mi, p)
    t0 = time.time()
    res, fn = simulate_machine(p, recs, quick)
    print("%s: modes %s Hz; integrated %d recordings in %.0f s" % (
        m["name"], " ".join("%.0f" % x for x in fn), len(recs), time.time() - t0), flush=True)
    fs = p["fs"]
    ref = None
    # PCM full scale: the logger's range set once for the machine, 1.3 x the largest raw peak of any of its
    # recordings (dynamics + 15 x rms glitch margin), so nothing clips
    peak = max(np.abs(rr["acc"]).max() for rr in res)
    for (name, f, seed), rr in zip(recs, res):
        acc = rr["acc"]
        n = len(acc)
        r = rr["r"]
        tt = np.arange(n) / fs
        if ref is None:
            ref = dict(rms=float(acc.std()))
        rms = ref["rms"]
        gs = smooth_random(r, tt, 0.02, 0.3, 5)
        y = acc * (1 + p["gain_var"] * gs / np.abs(gs).max())
        y = y + p["noise_rel"] * rms * pink_noise(r, n, fs)
        hum = np.zeros(n)
        for h, c in ((1, 1.0), (2, 0.3), (3, 0.5), (5, 0.25), (7, 0.12)):
            hum += c * np.sin(2 * np.pi * h * p["hum_hz"] * (1 + 2e-4 * r.normal()) * tt + r.uniform(0, 6.3))
        y = y + p["hum_rel"] * rms * hum / hum.std()
        y = y + p["dc"] * (1 + 0.01 * r.normal())
        nsp = r.poisson(p["spike_rate"] * n / fs)
        spikes = []
        for _ in range(nsp):
            i = int(r.integers(2, n - 4))
            amp = r.uniform(4, 15) * rms * r.choice([-1, 1])
            if r.uniform() < 0.5:
                y[i] += amp
                spikes.append([i, 1])
            else:
                y[i:i + 3] += amp * np.array([0.6, 1.0, -0.4])
                spikes.append([i, 3])
        tach = tacho(rr["phi"], fs, r, p["tacho_hi"])
        data = np.stack([y, tach], 1)
        path = os.path.join(d, name + ".wav")
        clipped = 0
        fsc = None
        if m["fmt"] == "f32":
            write_wav(path, data, fs, "f32")
            write_json(path + ".json", sidecar(path, p, n, seed))
        else:
            if "fsc" not in ref:
                ref["fsc"] = float(np.ceil(1.3 * peak + 20 * rms + abs(p["dc"])))
            fsc = [ref["fsc"], 16.0]
            clipped = int((np.abs(y) >= fsc[0]).sum())
            write_wav(path, data, fs, m["fmt"], fsc)
        fin = rr["f_in"]
        truth = dict(
            file=path, machine=m["name"], zp=p["zp"], zw=p["zw"], fs=fs, format=m["fmt"],
            sidecar=m["fmt"] == "f32",
            int16_full_scale=fsc[0] if fsc else None,
            pcm_full_scale=fsc, clipped_samples=clipped,
            nominal_rpm=p["nominal_rpm"], nominal_speed_hz=p["nominal_rpm"] / 60.0,
            speed_fluctuation=p["speed_fluct"], load_fluctuation=p["load_fluct"], contact_ratio=p["eps"],
            noise_rel=p["noise_rel"],
            fault=None if f is None else f["kind"],
            severity=None if f is None else f["severity"],
            gear=None if f is None else ("pinion" if f["gear"] == "p" else "wheel"),
            tooth=None if (f is None or f["kind"] in ("wear", "eccentricity")) else f["tooth"] + 1,
            ecc_um=None if f is None else f.get("ecc_um"),
            spall=None if (f is None or f["kind"] != "spall") else dict(
                path=[f["spall_lo"], f["spall_hi"]], face_width_share=f["spall_fw"], depth_um=f["spall_depth"]),
            wear_depth_um=None if (f is None or f["kind"] != "wear") else f["wear_depth"],
            seed=seed, aux_mesh_hz=0.0, aux_teeth=None, fan_blades=None,
            hum_hz=p["hum_hz"], dc_offset=p["dc"], spikes=spikes,
            structural_modes_hz=[float(x) for x in fn], panel_hz=p["panel_hz"],
            healthy_rms=rms, rms=float(y.std()), dyn_rms=float(acc.std()),
            true_mean_speed_hz=float(np.mean(fin)), speed_min_hz=float(fin.min()), speed_max_hz=float(fin.max()),
            start_revolutions_before_first_edge=float(rr["start"]),
            tacho="optical PNP, 0.3 V low / %.1f V high, 3 %% duty, RC rise tau 8 us; angle 0 = rising edge mid-level" % p["tacho_hi"],
            generator="tests/holdout/gen_third.py",
        )
        write_json(os.path.join(d, name + ".truth.json"), truth)
        print("  %s: rms %.3f (dyn %.3f) speed %.3f Hz nominal %.0f rpm" % (
            name, y.std(), acc.std(), truth["true_mean_speed_hz"], p["nominal_rpm"]), flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="/tmp/third")
    ap.add_argument("--machines", default=None)
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    sel = range(len(MACHINES))
    if a.machines:
        want = a.machines.split(",")
        sel = [i for i, m in enumerate(MACHINES) if m["name"].split("-")[0] in want or m["name"] in want]
    for i in sel:
        generate_machine(i, MACHINES[i], a.out, a.quick)


if __name__ == "__main__":
    sys.exit(main())
