#!/usr/bin/env python3
"""Fourth, independent hold-out generator: torsional-lateral spur-gear model with a potential-energy mesh stiffness.

Model (written without reference to gearvib or to the other generators' physics):
  * Geometry: involute spur pair, 20 deg pressure angle, profile shift on small pinions (zero-sum, standard centre
    distance). Pinion roll s along the line of action is measured from the pinion's base tangency point T1.
  * Per-tooth compliance by the potential-energy method: bending, shear and axial-compressive energy of a
    cantilever of the true involute half-thickness (straight flank below the base circle), integrated numerically
    from the root to the contact point, plus a fillet-foundation compliance of Sainsot's form with fixed
    representative coefficients, plus Hertzian contact. Pair stiffness = 1 / sum of the compliances.
  * Faults: root crack at 45 deg, depth found by bisection so that the pair stiffness at the worst point of the
    path drops by the severity (the tension side of every cracked section is clamped, Chen-Shao style); spall =
    loss of contact width over a patch near the pitch line (stiffness x (1 - width share)) plus a small profile dip
    on the remaining width; broken tooth = 70-85 % of the face width broken off over the whole tooth height (only
    the remaining width carries, over its whole pitch); distributed wear = sliding-weighted material loss of
    8-14 um (zero at the pitch line, more on the dedendum) on every tooth of one gear; eccentricity = run-out of
    50-90 um: a transmission error once per turn of that gear and a centre-distance modulation that moves the
    wheel's tip engagement point (contact-ratio modulation).
  * Fixed per machine (shared by healthy siblings): pitch, profile-slope and profile-form error of every tooth,
    run-out of both gears, linear tip relief; contact outside the nominal path (tip-corner contact) is possible at a
    separation growing with the square of the roll beyond the tip.
  * Dynamics, 7 DOF in deviations from the rigid-body kinematics: pinion and wheel torsion, load inertia torsion,
    pinion and wheel bearing translations along and across the line of action. Stiff speed-controlled motor
    (prescribed angle, 0.5-2 % smooth fluctuation + 100 ppm drift) behind a flexible coupling, output shaft to a
    load inertia with a 3-8 % fluctuating torque. Every tooth pair carries its own unilateral contact with its own
    errors (contact loss and free flight within the backlash included); sliding friction reversing at the pitch
    point acts across the line of action. Fixed-step explicit RK4 at >= 50 kHz (and >= 8 x the highest mode), the
    11 recordings of a machine integrated in one batch.
  * Transfer path: bearing-housing forces projected on the sensor axis, the pinion bearing's path gain modulated
    by the pinion's angle (shaft bow moving the load zone), the wheel bearing's path delayed and attenuated; each
    path is a parallel bank of modal accelerances (bilinear IIR sections).
  * Measurement chain: 8th-order Butterworth anti-alias at 0.42 fs (also on the tachometer), decimation, slowly
    varying sensor gain, DC offset, white + 1/f noise at 0.35-0.7 of the gear signal's rms, mains hum with
    harmonics, random structural shocks, a fan tone locked to the input shaft, auxiliary machine tones (an unrelated
    gear mesh on some machines), quantisation for integer formats. Tachometer: TTL square (float machines, with a
    sidecar) or an optical probe with RC edges (PCM machines, no sidecar); the rising edge's mid-level crossing is
    pinion angle 0.
  * Truth: speed_fluctuation and load_fluctuation are the peak relative amplitudes of the smooth random parts.
Tooth n of a gear is centred (n - 1/2)/z of a revolution after its origin (pinion: the tachometer's rising edge;
wheel: its angle at the first rising edge in the file).

Usage: gen_fourth.py [--out /tmp/fourth] [--jobs 2] [--machines m30,m31]
"""

import argparse
import json
import os
import struct
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from scipy import signal

A0 = np.deg2rad(20.0)
E_ST, NU, RHO = 2.06e11, 0.3, 7850.0
G_ST = E_ST / (2 * (1 + NU))
SAINSOT = (5.5, 1.3, 0.4, 0.1)  # L*, M*, P*, Q* of the fillet-foundation compliance
EXT_RADIUS = 1.0  # tip-corner contact beyond a tooth's tip: separation (roll beyond)^2 / (2 EXT_RADIUS module)
T_PRE = 0.3  # s of simulation discarded before the file starts
GENERATOR = "tests/holdout/gen_fourth.py"

MACHINES = [
    dict(idx=30, zp=17, zw=31, fs=25600, dur=12.0, fmt="f32", f_in=24.6, module=4.0, face=0.040, pattern="A",
         tach="ttl", mains=50.0, aux_mesh=False),
    dict(idx=31, zp=23, zw=59, fs=44100, dur=10.0, fmt="i24", f_in=36.3, module=3.0, face=0.032, pattern="B",
         tach="optical", mains=60.0, aux_mesh=True),
    dict(idx=32, zp=26, zw=41, fs=20000, dur=16.0, fmt="f32", f_in=13.2, module=4.5, face=0.045, pattern="A",
         tach="ttl", mains=50.0, aux_mesh=True),
    dict(idx=33, zp=19, zw=46, fs=48000, dur=11.0, fmt="i16", f_in=29.7, module=3.5, face=0.036, pattern="B",
         tach="optical", mains=60.0, aux_mesh=False),
    dict(idx=34, zp=14, zw=33, fs=32000, dur=13.0, fmt="f32", f_in=19.3, module=5.0, face=0.050, pattern="A",
         tach="ttl", mains=50.0, aux_mesh=False),
]

# (file stem, fault, severity, gear) for pattern A; pattern B swaps every gear except the two spalls
PATTERN_A = [
    ("crack10", "crack", 0.10, "pinion"),
    ("crack25", "crack", 0.25, "wheel"),
    ("crack50", "crack", 0.50, "pinion"),
    ("spall", "spall", 1.0, "pinion"),
    ("spall", "spall", 1.0, "wheel"),
    ("broken", "broken", 1.0, "wheel"),
    ("wear", "wear", 1.0, "pinion"),
    ("eccentricity", "eccentricity", 1.0, "wheel"),
]


def fault_list(pattern):
    other = {"pinion": "wheel", "wheel": "pinion"}
    if pattern == "A":
        return list(PATTERN_A)
    return [(s, f, v, g if f == "spall" else other[g]) for s, f, v, g in PATTERN_A]


# ---------------------------------------------------------------------------------------------------------
# geometry and potential-energy tooth compliance


def inv(a):
    return np.tan(a) - a


class Gear:
    def __init__(self, z, m, x, b):
        self.z, self.m, self.x, self.b = z, m, x, b
        self.r = m * z / 2
        self.rb = self.r * np.cos(A0)
        self.ra = self.r + m * (1 + x)
        self.rf = self.r - m * (1.25 - x)
        self.a2 = (np.pi / 2 + 2 * x * np.tan(A0)) / z + inv(A0)  # half tooth angle at the base circle

    def psi(self, rho):
        """Half tooth angle of the involute at radius rho."""
        return self.a2 - inv(np.arccos(np.clip(self.rb / rho, -1, 1)))

    def sections(self, n=2400):
        """Centre-line coordinate X and half thickness H of the tooth from the root to the tip."""
        hb = self.rb * np.sin(self.a2)
        if self.rf < self.rb:
            x_root, x_base = np.sqrt(self.rf**2 - hb**2), self.rb * np.cos(self.a2)
            x1 = np.linspace(x_root, x_base, n // 4, endpoint=False)
            h1 = np.full_like(x1, hb)
            rho = np.linspace(self.rb, self.ra, n)
        else:
            x1 = h1 = np.zeros(0)
            rho = np.linspace(self.rf, self.ra, n)
        p = self.psi(rho)
        return np.r_[x1, rho * np.cos(p)], np.r_[h1, rho * np.sin(p)]

    def compliance(self, rk, crack=0.0):
        """Bending + shear + axial + fillet-foundation compliance (m/N) for contact at radii rk; crack = depth (m)
        of a root crack at 45 deg."""
        X, H = self.sections()
        h_root = H[0]
        ht = np.minimum(H, h_root - crack * np.sin(np.pi / 4))
        T = np.maximum(H + ht, 0.05 * H)
        inertia, area = self.b * T**3 / 12, self.b * T
        rk = np.clip(rk, max(self.rb, self.rf) * (1 + 1e-9), self.ra)
        pk = self.psi(rk)
        xk, hk = rk * np.cos(pk), rk * np.sin(pk)
        a1 = np.arccos(self.rb / rk) - pk
        ca, sa = np.cos(a1)[:, None], np.sin(a1)[:, None]
        dx = np.gradient(X)[None, :] * (X[None, :] <= xk[:, None])
        moment = ca * (xk[:, None] - X[None, :]) - sa * hk[:, None]
        c = (moment**2 / (E_ST * inertia) + 1.2 * ca**2 / (G_ST * area) + sa**2 / (E_ST * area)) * dx
        uf, sf = xk - hk * np.tan(a1) - X[0], 2 * h_root
        L_, M_, P_, Q_ = SAINSOT
        r = uf / sf
        cf = np.cos(a1) ** 2 / (E_ST * self.b) * (L_ * r**2 + M_ * r + P_ * (1 + Q_ * np.tan(a1) ** 2))
        return c.sum(1) + cf


class Mesh:
    """The pair's path of contact and the healthy compliance tables of both gears (roll coordinates)."""

    def __init__(self, zp, zw, m, b):
        x = 0.3 if zp < 17 else (0.1 if zp < 22 else 0.0)
        self.p, self.w = Gear(zp, m, x, b), Gear(zw, m, -x, b)
        self.zp, self.zw = zp, zw
        self.a = self.p.r + self.w.r
        self.rsum = self.p.rb + self.w.rb
        self.L = np.sqrt(self.a**2 - self.rsum**2)
        self.pb = 2 * np.pi * self.p.rb / zp
        self.s_end = np.sqrt(self.p.ra**2 - self.p.rb**2)  # pinion tip
        self.uw_tip = np.sqrt(self.w.ra**2 - self.w.rb**2)  # wheel tip, in wheel roll (from T2)
        self.s_start = self.L - self.uw_tip
        self.s_pitch = self.L * self.p.rb / self.rsum
        self.cr = (self.s_end - self.s_start) / self.pb
        if not (self.s_start > 0.05 * self.pb and 1.2 < self.cr < 2.0):
            raise ValueError("bad mesh geometry %d/%d: s_start/pb %.2f, contact ratio %.2f"
                             % (zp, zw, self.s_start / self.pb, self.cr))
        self.ext = 0.4 * self.pb
        self.s_lo, self.s_hi = self.s_start - self.ext, self.s_end + self.ext
        self.ch = 4 * (1 - NU**2) / (np.pi * E_ST * b)  # Hertz
        self.grid_p = np.linspace(max(self.s_lo, 0.0), self.s_end, 500)
        self.grid_w = np.linspace(max(self.L - self.s_hi - 0.002, 0.0), self.uw_tip, 500)
        self.cp = self.compl("pinion", self.grid_p)
        self.cw = self.compl("wheel", self.grid_w)

    def gear(self, which):
        return self.p if which == "pinion" else self.w

    def compl(self, which, u, crack=0.0):
        g = self.gear(which)
        return g.compliance(np.sqrt(g.rb**2 + np.maximum(u, 0) ** 2), crack)

    def active(self, which):
        """Own-roll span of the active profile (start, tip) and own pitch-point roll."""
        if which == "pinion":
            return self.s_start, self.s_end, self.s_pitch
        return self.L - self.s_end, self.uw_tip, self.L - self.s_pitch

    def crack_depth(self, which, severity):
        """Crack depth that lowers the pair stiffness by `severity` at the worst point of this tooth's path."""
        ua, ut, _ = self.active(which)
        u = np.linspace(ua, ut, 80)
        s = u if which == "pinion" else self.L - u
        c_self = self.compl(which, u)
        c_mate = self.compl("wheel", self.L - s) if which == "pinion" else self.compl("pinion", s)
        k0 = 1 / (self.ch + c_self + c_mate)
        lo, hi = 0.0, 2.5 * self.gear(which).sections()[1][0]
        for _ in range(40):
            q = (lo + hi) / 2
            r = (1 / (self.ch + self.compl(which, u, q) + c_mate) / k0).min()
            lo, hi = (q, hi) if r > 1 - severity else (lo, q)
        return (lo + hi) / 2

    def mean_k(self):
        phi = np.linspace(0, 2 * np.pi / self.zp, 400, endpoint=False)
        tot = np.zeros_like(phi)
        for k in range(-3, 4):
            s = self.s_pitch + self.p.rb * phi - (k + 0.5) * self.pb
            ok = (s >= self.s_start) & (s <= self.s_end)
            kk = 1 / (self.ch + np.interp(s, self.grid_p, self.cp) + np.interp(self.L - s, self.grid_w, self.cw))
            tot += kk * ok
        return tot.mean()


def smooth_window(u, centre, length):
    """1 inside the patch, cosine tapers over 20 % of its length at both ends."""
    d = np.abs(u - centre)
    taper = 0.2 * length
    return np.clip(np.where(d < length / 2 - taper, 1.0, 0.5 * (1 + np.cos(np.pi * (d - length / 2 + taper) / taper))),
                   0, 1) * (d < length / 2)


class ToothSet:
    """Errors, stiffness multiplier and compliance of every tooth of one gear (roll coordinate u of that gear)."""

    def __init__(self, mesh, which, man):
        self.mesh, self.which = mesh, which
        self.ua, self.ut, self.upitch = mesh.active(which)
        self.man = man  # manufacturing: pitch, slope, form (arrays per tooth), relief, l_rel
        self.grid = mesh.grid_p if which == "pinion" else mesh.grid_w
        self.c_h = mesh.cp if which == "pinion" else mesh.cw
        self.fault = None

    def error(self, n, u):
        m = self.man
        xi = np.clip((u - (self.ua + self.ut) / 2) / ((self.ut - self.ua) / 2), -1, 1)
        e = m["pitch"][n] + m["slope"][n] * xi + m["form"][n] * (xi**2 - 1 / 3)
        e = e + m["relief"] * np.clip((u - self.ut + m["l_rel"]) / m["l_rel"], 0, 1)
        e = e + np.maximum(u - self.ut, 0) ** 2 / (2 * EXT_RADIUS * self.mesh.p.m)
        f = self.fault
        if f is None:
            return e
        if f["kind"] == "wear":
            span = np.where(u < self.upitch, self.upitch - self.ua, self.ut - self.upitch)
            prof = np.clip(np.abs(u - self.upitch) / span, 0, 1) * np.where(u < self.upitch, 1.0, 0.6)
            e = e + f["depth"] * f["scatter"][n] * prof
        elif f["kind"] == "spall":
            e = e + (n == f["tooth0"]) * f["dip"] * smooth_window(u, f["centre"], f["length"])
        return e

    def mult(self, n, u):
        f = self.fault
        if f is None or f["kind"] not in ("spall", "broken"):
            return 1.0
        if f["kind"] == "broken":
            return np.where(n == f["tooth0"], 1 - f["width"], 1.0)
        return 1 - (n == f["tooth0"]) * f["width"] * smooth_window(u, f["centre"], f["length"])

    def compliance(self, n, u):
        c = np.interp(u, self.grid, self.c_h)
        f = self.fault
        if f is not None and f["kind"] == "crack":
            c = np.where(n == f["tooth0"], np.interp(u, self.grid, f["table"]), c)
        return c


# ---------------------------------------------------------------------------------------------------------
# machine parameters


def smooth_random(rng, fmin, fmax, n=6):
    return dict(f=rng.uniform(fmin, fmax, n), ph=rng.uniform(0, 2 * np.pi, n), a=rng.uniform(0.4, 1.0, n))


def sr_eval(p, t, kind="x"):
    """Unit-peak smooth random signal (kind x), its integral (X) or derivative (dx)."""
    w = 2 * np.pi * p["f"]
    arg = w[None, :] * np.asarray(t)[:, None] + p["ph"][None, :]
    if kind == "x":
        v = (p["a"] * np.cos(arg)).sum(1)
    elif kind == "X":
        v = (p["a"] / w * (np.sin(arg) - np.sin(p["ph"]))).sum(1)
    else:
        v = (-p["a"] * w * np.sin(arg)).sum(1)
    return v / p["peak"]


def sr_make(rng, fmin, fmax, t0, t1):
    p = smooth_random(rng, fmin, fmax)
    p["peak"] = 1.0
    p["peak"] = np.abs(sr_eval(p, np.arange(t0, t1, 0.002))).max()
    return p


def machine_params(mc):
    rng = np.random.default_rng(4000 + mc["idx"])
    zp, zw, m, b = mc["zp"], mc["zw"], mc["module"] * 1e-3, mc["face"]
    mesh = Mesh(zp, zw, m, b)
    P = dict(mc)
    P["name"] = "m%d-z%dz%d" % (mc["idx"], zp, zw)
    P["mesh"] = mesh
    P["N0"] = rng.uniform(170, 280) * b * 1e3  # load intensity 170-280 N/mm
    rp, rw = mesh.p.r, mesh.w.r
    P["Ip"] = rng.uniform(1.4, 2.0) * 0.5 * RHO * np.pi * b * rp**4
    P["mp"] = 1.2 * RHO * np.pi * rp**2 * b + rng.uniform(1.5, 3.0)
    P["Iw"] = rng.uniform(0.8, 1.1) * 0.5 * RHO * np.pi * b * rw**4
    P["mw"] = 0.8 * RHO * np.pi * rw**2 * b + rng.uniform(2.0, 5.0)
    P["Il"] = rng.uniform(5, 15) * P["Iw"]
    P["kc1"], P["kc2"] = rng.uniform(1e4, 4e4), rng.uniform(4e4, 1.2e5)
    P["kbp"], P["kbw"] = rng.uniform(2.5e8, 5e8), rng.uniform(3e8, 6e8)
    P["kx_ratio"] = rng.uniform(0.7, 1.2)
    P["zeta_b"], P["zeta_t"], P["zeta_m"] = rng.uniform(0.03, 0.06), 0.04, rng.uniform(0.04, 0.08)
    P["mu"] = rng.uniform(0.04, 0.07)
    P["kbar"] = mesh.mean_k()
    # manufacturing errors (fixed per machine)
    sig_p = rng.uniform(0.8, 1.8) * 1e-6  # ground gears, ISO 1328 grade 4-5
    man = {}
    for g, z in (("pinion", zp), ("wheel", zw)):
        man[g] = dict(pitch=rng.normal(0, sig_p, z), slope=rng.normal(0, 1.0e-6, z), form=rng.normal(0, 0.5e-6, z),
                      relief=rng.uniform(6e-6, 12e-6), l_rel=0.25 * mesh.pb)
    P["man"] = man
    P["runout"] = {g: (rng.uniform(4e-6, 10e-6), rng.uniform(0, 2 * np.pi)) for g in ("pinion", "wheel")}
    # sensor and transfer path
    P["beta"], P["beta2"] = rng.uniform(np.deg2rad(20), np.deg2rad(70)), rng.uniform(np.deg2rad(10), np.deg2rad(80))
    P["mod_a"], P["mod_ph"] = rng.uniform(0.02, 0.05), rng.uniform(0, 2 * np.pi)
    P["path2_gain"], P["path2_delay"] = rng.uniform(0.2, 0.45), rng.uniform(0.15e-3, 0.5e-3)
    fs = mc["fs"]
    fhi = min(7500.0, 0.38 * fs)
    P["modes1"] = [(250.0, 0.6, rng.uniform(60, 120))] + [
        (rng.uniform(lo, hi), rng.uniform(0.02, 0.05), rng.uniform(30, 100))
        for lo, hi in ((900, 1800), (2200, 3800), (4000, fhi))]
    P["modes2"] = [(rng.uniform(1200, 2500), rng.uniform(0.02, 0.05), rng.uniform(40, 120)),
                   (rng.uniform(3000, min(6000, fhi)), rng.uniform(0.02, 0.05), rng.uniform(40, 120))]
    # measurement chain levels (relative to the first healthy recording's gear signal rms)
    P["noise_rel"], P["pink"] = rng.uniform(0.35, 0.7), rng.uniform(0.2, 0.5)
    P["hum"] = rng.uniform(0.05, 0.2) * np.array([1.0, 0.5, 0.35, 0.2, 0.1]) * rng.uniform(0.5, 1.0, 5)
    P["dc"], P["gain_drift"] = rng.uniform(-0.05, 0.05), rng.uniform(0.01, 0.03)
    P["shock_rate"], P["shock_amp"] = rng.uniform(0.3, 2.0), rng.uniform(3, 6)
    P["fan_blades"] = int(rng.choice([b_ for b_ in (5, 7, 9, 11) if b_ != zp]))
    P["fan_amp"] = rng.uniform(0.05, 0.15)
    fmesh = mc["f_in"] * zp
    if mc["aux_mesh"]:
        while True:
            fa = rng.uniform(300, 1500)
            if min(abs(fa / fmesh - k) for k in range(0, 6)) * fmesh > 0.1 * fmesh:
                break
        P["aux"] = dict(mesh_hz=fa, shaft_hz=fa / rng.integers(20, 40), amp=rng.uniform(0.1, 0.25))
        P["aux_tones"] = []
    else:
        P["aux"] = None
        f0 = rng.uniform(17, 60)
        P["aux_tones"] = [(f0 * k, rng.uniform(0.03, 0.08) / k) for k in range(1, 5)]
    P["slip"] = rng.uniform(0.008, 0.025)
    P["speed_fluct"], P["load_fluct"] = rng.uniform(0.005, 0.02), rng.uniform(0.03, 0.08)
    P["nominal_rpm"] = float(round(mc["f_in"] * 60 * (1 + P["slip"]), -1))
    if mc["tach"] == "ttl":
        P["tach_par"] = dict(lo=0.02, hi=rng.uniform(4.85, 5.0), duty=rng.uniform(0.15, 0.45),
                             tau=rng.uniform(2e-6, 10e-6))
    else:
        P["tach_par"] = dict(lo=rng.uniform(0.2, 0.4), hi=rng.uniform(4.4, 4.7), duty=rng.uniform(0.03, 0.08),
                             tau=rng.uniform(30e-6, 60e-6))
    # faults (fixed per machine): teeth and sizes
    faults = []
    used = {"pinion": set(), "wheel": set()}
    for stem, kind, sev, g in fault_list(mc["pattern"]):
        z = zp if g == "pinion" else zw
        f = dict(stem=stem, kind=kind, severity=sev, gear=g, tooth=None)
        if kind in ("crack", "spall", "broken"):
            t = int(rng.integers(1, z + 1))
            while t in used[g]:
                t = int(rng.integers(1, z + 1))
            used[g].add(t)
            f["tooth"], f["tooth0"] = t, t - 1
        if kind == "broken":
            f["width"] = rng.uniform(0.7, 0.85)
        if kind == "crack":
            f["depth"] = mesh.crack_depth(g, sev)
            grid = mesh.grid_p if g == "pinion" else mesh.grid_w
            f["table"] = mesh.compl(g, grid, f["depth"])
        elif kind == "spall":
            upitch = mesh.active(g)[2]
            big = g == "pinion"
            f["length"] = rng.uniform(0.10, 0.18) * mesh.pb if big else rng.uniform(0.06, 0.12) * mesh.pb
            f["width"] = rng.uniform(0.30, 0.45) if big else rng.uniform(0.20, 0.35)
            f["dip"] = rng.uniform(1e-6, 3e-6)
            f["centre"] = upitch - rng.uniform(0.0, 0.15) * mesh.pb
        elif kind == "wear":
            f["depth"] = rng.uniform(8e-6, 14e-6)
            f["scatter"] = np.clip(rng.normal(1, 0.15, z), 0.5, 1.5)
        elif kind == "eccentricity":
            f["ecc"], f["ecc_ph"] = rng.uniform(50e-6, 90e-6), rng.uniform(0, 2 * np.pi)
        faults.append(f)
    P["faults"] = faults
    return P


# ---------------------------------------------------------------------------------------------------------
# dynamics


def system_matrices(P):
    mesh = P["mesh"]
    rbp, rbw = mesh.p.rb, mesh.w.rb
    masses = np.array([P["Ip"], P["Iw"], P["Il"], P["mp"], P["mw"], P["mp"], P["mw"]])
    K = np.zeros((7, 7))
    K[0, 0] = P["kc1"]
    K[1, 1] = K[2, 2] = P["kc2"]
    K[1, 2] = K[2, 1] = -P["kc2"]
    K[3, 3], K[4, 4] = P["kbp"], P["kbw"]
    K[5, 5], K[6, 6] = P["kbp"] * P["kx_ratio"], P["kbw"] * P["kx_ratio"]
    C = np.zeros((7, 7))
    ct1 = 2 * P["zeta_t"] * np.sqrt(P["kc1"] * P["Ip"])
    ct2 = 2 * P["zeta_t"] * np.sqrt(P["kc2"] * P["Iw"] * P["Il"] / (P["Iw"] + P["Il"]))
    C[0, 0] = ct1
    C[1, 1] = C[2, 2] = ct2
    C[1, 2] = C[2, 1] = -ct2
    for i in range(3, 7):
        C[i, i] = 2 * P["zeta_b"] * np.sqrt(K[i, i] * masses[i])
    gd = np.array([rbp, -rbw, 0, 1, -1, 0, 0])  # mesh compression per DOF
    me = 1 / (rbp**2 / P["Ip"] + rbw**2 / P["Iw"])
    cm = 2 * P["zeta_m"] * np.sqrt(P["kbar"] * me)
    minv = 1 / masses
    A = np.zeros((14, 14))
    A[7:, :7] = np.eye(7)
    A[:7, 7:] = (-minv[:, None] * K).T
    A[7:, 7:] = (-minv[:, None] * C).T
    G2 = np.zeros((14, 2))
    G2[:7, 0] = gd
    G2[7:, 1] = gd
    cb, sb, cb2, sb2 = np.cos(P["beta"]), np.sin(P["beta"]), np.cos(P["beta2"]), np.sin(P["beta2"])
    W = np.zeros((14, 3))  # housing forces on the sensor axis at both bearings, pinion torsion
    W[3, 0], W[5, 0] = cb * K[3, 3], sb * K[5, 5]
    W[10, 0], W[12, 0] = cb * C[3, 3], sb * C[5, 5]
    W[4, 1], W[6, 1] = cb2 * K[4, 4], sb2 * K[6, 6]
    W[11, 1], W[13, 1] = cb2 * C[4, 4], sb2 * C[6, 6]
    W[0, 2] = 1.0
    Kt = K + P["kbar"] * np.outer(gd, gd)
    freqs = np.sqrt(np.abs(np.linalg.eigvals(minv[:, None] * Kt))) / (2 * np.pi)
    return dict(A=A, G2=G2, W=W, minv=minv, Kt=Kt, cm=cm, freqs=np.sort(freqs))


def recording_list(P):
    out = [dict(name="healthy-s%d" % (i + 1), fault=None, seed=(4000 + P["idx"]) * 100 + i + 1) for i in range(3)]
    for j, f in enumerate(P["faults"]):
        out.append(dict(name="%s-%s" % (f["stem"], f["gear"]), fault=f, seed=(4000 + P["idx"]) * 100 + 10 + j))
    return out


def realisation(P, rec):
    """Speed, load and measurement-noise realisation of one recording (its own seed)."""
    rng = np.random.default_rng(rec["seed"])
    T = P["dur"]
    R = dict(rng=rng)
    R["f_mean"] = P["f_in"] * (1 + rng.normal(0, 0.0015))
    R["phi0"] = rng.uniform(0.2, 0.8) * 2 * np.pi
    R["speed"] = sr_make(rng, 0.05, 1.5, -T_PRE, T)
    R["drift"] = rng.choice([-1, 1]) * 100e-6
    R["load"] = sr_make(rng, 0.1, 3.0, -T_PRE, T)
    return R


def pinion_angle(P, R, t, kind="phi"):
    T, om = P["dur"], 2 * np.pi * R["f_mean"]
    A, D = P["speed_fluct"], R["drift"]
    if kind == "phi":
        return -R["phi0"] + om * (t + A * sr_eval(R["speed"], t, "X") + D * (t**2 / (2 * T) - t / 2))
    if kind == "omega":
        return om * (1 + A * sr_eval(R["speed"], t, "x") + D * (t / T - 0.5))
    return om * (A * sr_eval(R["speed"], t, "dx") + D / T)


def gear_sets(P, rec):
    mesh = P["mesh"]
    sets = {g: ToothSet(mesh, g, P["man"][g]) for g in ("pinion", "wheel")}
    ecc = dict(P["runout"])
    f = rec["fault"]
    if f is not None:
        if f["kind"] == "eccentricity":
            e0, ph0 = ecc[f["gear"]]
            z = e0 * np.exp(1j * ph0) + f["ecc"] * np.exp(1j * f["ecc_ph"])
            ecc[f["gear"]] = (abs(z), np.angle(z))
        else:
            sets[f["gear"]].fault = f
    return sets, ecc


def precompute(P, S, recs, reals, sets, t2):
    """Per half-step time t2 and recording: pair stiffness K, error E, damping Cc, force directions D, forcing Pf."""
    mesh = P["mesh"]
    B, n2 = len(recs), len(t2)
    Kp, Ep, Cc = np.zeros((n2, B, 3)), np.zeros((n2, B, 3)), np.zeros((n2, B, 3))
    D = np.zeros((n2, B, 3, 14))
    Pf = np.zeros((n2, B, 14))
    rbp, rbw, g = mesh.p.rb, mesh.w.rb, P["zp"] / P["zw"]
    minv = S["minv"]
    gn = np.array([-rbp, rbw, 0, -1, 1, 0, 0]) * minv
    gf1 = np.array([0, mesh.L, 0, 0, 0, 1, -1]) * minv
    gf2 = np.array([-1, -1, 0, 0, 0, 0, 0]) * minv
    T0 = P["N0"] * rbw
    w0 = rbp * P["N0"] / P["kc1"]
    for b in range(B):
        R = reals[b]
        phi = pinion_angle(P, R, t2)
        acc = pinion_angle(P, R, t2, "acc")
        ths = {"pinion": phi, "wheel": g * phi}
        te = np.zeros(n2)
        da = np.zeros(n2)
        for gg, (e, ph) in sets[b][1].items():
            te += e * np.sin(ths[gg] + ph)
            da += e * np.cos(ths[gg] + ph)
        L = np.sqrt((mesh.a + da) ** 2 - mesh.rsum**2)
        s_pitch = L * rbp / mesh.rsum
        base = (mesh.s_pitch + rbp * phi - mesh.s_hi) / mesh.pb - 0.5
        k0 = np.ceil(base).astype(np.int64)
        sp, sw = sets[b][0]["pinion"], sets[b][0]["wheel"]
        for j in range(3):
            k = k0 + j
            s = mesh.s_pitch + rbp * phi - (k + 0.5) * mesh.pb
            valid = (s >= mesh.s_lo) & (s <= mesh.s_hi)
            uw = L - s
            n, m = np.mod(k, P["zp"]), np.mod(k, P["zw"])
            kk = sp.mult(n, s) * sw.mult(m, uw) / (mesh.ch + sp.compliance(n, s) + sw.compliance(m, uw)) * valid
            Kp[:, b, j] = kk
            Ep[:, b, j] = sp.error(n, s) + sw.error(m, uw) + te
            Cc[:, b, j] = S["cm"] * kk / P["kbar"]
            f = P["mu"] * np.tanh((s - s_pitch) / (0.02 * mesh.pb))
            D[:, b, j, 7:] = gn[None, :] + f[:, None] * (gf1[None, :] + s[:, None] * gf2[None, :])
        load = T0 * (1 + P["load_fluct"] * sr_eval(R["load"], t2))
        Pf[:, b, 7] = (P["kc1"] * w0 - P["Ip"] * acc) * minv[0]
        Pf[:, b, 8] = -g * acc
        Pf[:, b, 9] = -g * acc - load * minv[2]
    return Kp, Ep, Cc, D, Pf


def simulate(P, S, recs, reals, sets, fs_int, log):
    """RK4 of all recordings of a machine at once; returns the per-step outputs (steps, B, 3) and the step times."""
    h = 1.0 / fs_int
    n_pre = int(round(T_PRE * fs_int))
    n_tot = n_pre + int(round(P["dur"] * fs_int)) + 8
    B = len(recs)
    t_start = -n_pre * h
    # static initial state with the mean mesh stiffness
    mesh = P["mesh"]
    F = np.zeros(7)
    F[0] = mesh.p.rb * P["N0"]
    F[2] = -P["N0"] * mesh.w.rb
    q0 = np.linalg.solve(S["Kt"], F)
    x = np.tile(np.r_[q0, np.zeros(7)], (B, 1))
    A, G2, W = S["A"], S["G2"], S["W"]
    out = np.zeros((n_tot, B, 3), np.float32)

    def deriv(x, Ki, Ei, Ci, Di, Pi):
        X2 = x @ G2
        d = X2[:, :1] - Ei
        nj = np.maximum(Ki * d + Ci * X2[:, 1:2], 0.0) * (d > 0)
        return x @ A + (nj[:, None, :] @ Di)[:, 0, :] + Pi

    chunk = 4000
    t0 = time.time()
    for c0 in range(0, n_tot, chunk):
        nc = min(chunk, n_tot - c0)
        t2 = t_start + (c0 + np.arange(2 * nc + 1) / 2) * h
        Kp, Ep, Cc, D, Pf = precompute(P, S, recs, reals, sets, t2)
        for i in range(nc):
            a, bb, c = 2 * i, 2 * i + 1, 2 * i + 2
            k1 = deriv(x, Kp[a], Ep[a], Cc[a], D[a], Pf[a])
            k2 = deriv(x + 0.5 * h * k1, Kp[bb], Ep[bb], Cc[bb], D[bb], Pf[bb])
            k3 = deriv(x + 0.5 * h * k2, Kp[bb], Ep[bb], Cc[bb], D[bb], Pf[bb])
            k4 = deriv(x + h * k3, Kp[c], Ep[c], Cc[c], D[c], Pf[c])
            x = x + (h / 6) * (k1 + 2 * k2 + 2 * k3 + k4)
            out[c0 + i] = x @ W
        if not np.all(np.isfinite(x)):
            raise RuntimeError("%s: integration diverged at step %d" % (P["name"], c0))
        if c0 // chunk % 50 == 0:
            log("%s: step %d/%d (%.0f s)" % (P["name"], c0, n_tot, time.time() - t0))
    t_steps = t_start + (np.arange(n_tot) + 1) * h
    return out, t_steps, n_pre


# ---------------------------------------------------------------------------------------------------------
# transfer path and measurement chain


def modal_sos(modes, fs):
    """Accelerance (m/s^2 per N) of a set of modes (f, zeta, modal mass), one SOS bank per mode."""
    out = []
    for f, z, m in modes:
        w = 2 * fs * np.tan(np.pi * f / fs)  # pre-warped
        b_, a_ = signal.bilinear([1.0 / m, 0, 0], [1.0, 2 * z * w, w * w], fs)
        out.append(signal.tf2sos(b_, a_))
    return out


def edges(theta, t, level):
    """Times where theta - level crosses a multiple of 2 pi upwards (linear interpolation)."""
    n = np.floor((theta - level) / (2 * np.pi))
    i = np.flatnonzero(np.diff(n) > 0)
    target = 2 * np.pi * n[i + 1] + level
    return t[i] + (target - theta[i]) / (theta[i + 1] - theta[i]) * (t[i + 1] - t[i])


def tach_wave(t, rises, falls, init_high, kind, tp):
    lo, hi = tp["lo"], tp["hi"]
    if kind == "ttl":
        def ramps(e):
            e = np.r_[e, np.inf]
            i = np.searchsorted(e, t - tp["tau"] / 2)
            return i + np.clip((t - e[i]) / tp["tau"] + 0.5, 0, 1)
        state = ramps(rises) - ramps(falls) + init_high
        return lo + (hi - lo) * state
    # optical probe: RC edges, the rise's mid-level crossing at the edge time
    tau = tp["tau"]
    r0 = rises - tau * np.log(2)
    ev = np.r_[r0, falls]
    typ = np.r_[np.ones(len(r0)), np.zeros(len(falls))]
    o = np.argsort(ev)
    ev, typ = np.r_[-np.inf, ev[o]], np.r_[float(init_high), typ[o]]
    i = np.searchsorted(ev, t, side="right") - 1
    dt = np.where(np.isfinite(ev[i]), t - ev[i], 1.0)
    x = np.exp(-dt / tau)
    return np.where(typ[i] > 0, hi - (hi - lo) * x, lo + (hi - lo) * x)


def gear_vibration(P, out_b, theta, fs_int, sos1, sos2):
    p1 = out_b[:, 0].astype(float)
    p2 = out_b[:, 1].astype(float)
    p1 = (p1 - p1.mean()) * (1 + P["mod_a"] * np.cos(theta + P["mod_ph"]))
    p2 = p2 - p2.mean()
    nd = int(round(P["path2_delay"] * fs_int))
    p2 = np.r_[np.zeros(nd), p2[: len(p2) - nd]]
    y = sum(signal.sosfilt(s, p1) for s in sos1) + P["path2_gain"] * sum(signal.sosfilt(s, p2) for s in sos2)
    return y


def measurement(P, R, vib, t, phi, ref, fs):
    """Everything that is not the gears, at the output rate: returns the analog accelerometer signal and noise."""
    rng = R["rng"]
    n = len(t)
    T = P["dur"]
    gain = 1 + P["gain_drift"] * sr_eval(sr_make(rng, 0.02, 0.2, 0, T), t)
    extra = P["fan_amp"] * ref * (np.sin(P["fan_blades"] * phi + rng.uniform(0, 6.3))
                                  + 0.4 * np.sin(2 * P["fan_blades"] * phi + rng.uniform(0, 6.3)))
    if P["aux"] is not None:
        a = P["aux"]
        ph_s = 2 * np.pi * a["shaft_hz"] * t + rng.uniform(0, 6.3)
        fm_dev = 0.002 * a["mesh_hz"]  # 0.2 % frequency wander at 0.3 Hz
        ph_m = 2 * np.pi * a["mesh_hz"] * t + fm_dev / 0.3 * np.sin(2 * np.pi * 0.3 * t) + rng.uniform(0, 6.3)
        extra += a["amp"] * ref * (1 + 0.3 * np.cos(ph_s)) * (np.sin(ph_m) + 0.5 * np.sin(2 * ph_m + 1.0))
    for f, amp in P["aux_tones"]:
        extra += amp * ref * np.sin(2 * np.pi * f * t + rng.uniform(0, 6.3))
    nsh = rng.poisson(P["shock_rate"] * T)
    for ts in rng.uniform(0, T, nsh):
        i0 = int(ts * fs)
        f = rng.uniform(1500, 0.4 * fs)
        tau = rng.uniform(0.3e-3, 1.5e-3)
        L = min(int(8 * tau * fs), n - i0)
        tt = np.arange(L) / fs
        amp = P["shock_amp"] * ref * rng.lognormal(0, 0.4)
        extra[i0:i0 + L] += amp * np.exp(-tt / tau) * np.sin(2 * np.pi * f * tt)
    fm = P["mains"] * (1 + rng.normal(0, 0.001))
    hum = sum(a * ref * np.sin(2 * np.pi * (k + 1) * fm * t + rng.uniform(0, 6.3)) for k, a in enumerate(P["hum"]))
    white = rng.normal(size=n)
    X = np.fft.rfft(rng.normal(size=n))
    fr = np.fft.rfftfreq(n, 1 / fs)
    X *= np.where(fr > 0.5, 1 / np.sqrt(np.maximum(fr, 0.5)), 0)
    pink = np.fft.irfft(X, n)
    pink /= pink.std()
    noise = np.sqrt(1 - P["pink"]) * white + np.sqrt(P["pink"]) * pink
    noise = signal.sosfilt(signal.butter(8, 0.42 * fs, fs=fs, output="sos"), noise)
    noise *= P["noise_rel"] * ref / noise.std()
    analog = gain * (vib + extra) + hum + P["dc"] * ref + noise
    return analog, noise


def nice_ceil(x):
    e = 10 ** np.floor(np.log10(x))
    for m in (1, 2, 5, 10):
        if m * e >= x:
            return m * e
    return 10 * e


def write_wav(path, data, fs, fmt, full_scale=None):
    """data: (frames, channels). f32: IEEE float; i16/i24: PCM with per-channel full scales. Returns clipped count."""
    ch = data.shape[1]
    clipped = 0
    if fmt == "f32":
        body = data.astype("<f4").tobytes()
        tag, bits = 3, 32
    else:
        bits = 16 if fmt == "i16" else 24
        top = 2 ** (bits - 1)
        q = np.round(data / np.asarray(full_scale)[None, :] * (top - 1))
        clipped = int(((q[:, 0] > top - 1) | (q[:, 0] < -top)).sum())
        q = np.clip(q, -top, top - 1).astype("<i4")
        body = q.astype("<i2").tobytes() if bits == 16 else q.view(np.uint8).reshape(-1, 4)[:, :3].tobytes()
        tag = 1
    block = ch * bits // 8
    hdr = b"RIFF" + struct.pack("<I", 36 + len(body)) + b"WAVE"
    hdr += b"fmt " + struct.pack("<IHHIIHH", 16, tag, ch, int(fs), int(fs) * block, block, bits)
    hdr += b"data" + struct.pack("<I", len(body))
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(hdr)
        f.write(body)
    os.replace(tmp, path)
    return clipped


def write_json(path, obj):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(obj, f, indent=1)
    os.replace(tmp, path)


def sidecar(path, P, frames, seed):
    return {
        "file": os.path.basename(path),
        "scene": P["name"],
        "scene_file": "",
        "sample_rate_hz": float(P["fs"]),
        "frames": frames,
        "duration_s": frames / P["fs"],
        "channels": [
            {"name": "accel", "unit": "m/s^2", "description": "bearing housing accelerometer, radial"},
            {"name": "tacho pinion", "unit": "pulse",
             "description": "once per input revolution, TTL 0/5 V, rising edge at angle 0"},
        ],
        "format": "f32",
        "full_scale": None,
        "clipped_samples": 0,
        "noise_rms": 0.0,
        "seed": seed,
        "speed_change": None,
        "base_hz": P["nominal_rpm"] / 60.0,
        "period_s": 60.0 / P["nominal_rpm"],
        "evaluation": "fourth generator (tests/holdout/gen_fourth.py)",
        "warnings": [],
    }


# ---------------------------------------------------------------------------------------------------------


def make_machine(mc, out_dir):
    t_begin = time.time()

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    P = machine_params(mc)
    S = system_matrices(P)
    fs = P["fs"]
    os_f = max(1, int(np.ceil(max(50000.0, 8 * S["freqs"].max()) / fs)))
    fs_int = fs * os_f
    mesh = P["mesh"]
    log("%s: contact ratio %.3f, mean mesh stiffness %.3g N/m, static deflection %.1f um, modes %s Hz, internal %d Hz"
        % (P["name"], mesh.cr, P["kbar"], 1e6 * P["N0"] / P["kbar"], " ".join("%.0f" % f for f in S["freqs"]), fs_int))
    recs = recording_list(P)
    reals = [realisation(P, r) for r in recs]
    sets = [gear_sets(P, r) for r in recs]
    out, t_steps, n_pre = simulate(P, S, recs, reals, sets, fs_int, log)
    mdir = os.path.join(out_dir, P["name"])
    os.makedirs(mdir, exist_ok=True)
    sos1, sos2 = modal_sos(P["modes1"], fs_int), modal_sos(P["modes2"], fs_int)
    aa = signal.butter(8, 0.42 * fs, fs=fs_int, output="sos")
    n_out = int(round(P["dur"] * fs))
    t_out = np.arange(n_out) / fs
    ref = fs_acc = None
    for b, rec in enumerate(recs):
        R = reals[b]
        phi_steps = pinion_angle(P, R, t_steps)
        theta = phi_steps + out[:, b, 2]
        y = gear_vibration(P, out[:, b], theta, fs_int, sos1, sos2)
        tp = P["tach_par"]
        rises, falls = edges(theta, t_steps, 0.0), edges(theta, t_steps, 2 * np.pi * tp["duty"])
        init_high = float(np.mod(theta[0], 2 * np.pi) < 2 * np.pi * tp["duty"])
        tach = tach_wave(t_steps, rises, falls, init_high, mc["tach"], tp)
        tach = tach + R["rng"].normal(0, 0.01, len(tach))
        y = signal.sosfilt(aa, y)
        tach = signal.sosfilt(aa, tach)
        # output sample j is the internal step at time j / fs
        i0 = n_pre - 1
        vib = y[i0::os_f][:n_out]
        tach = tach[i0::os_f][:n_out]
        if ref is None:
            ref = float(np.std(vib))
        phi_out = pinion_angle(P, R, t_out)
        analog, noise = measurement(P, R, vib, t_out, phi_out, ref, fs)
        if mc["fmt"] != "f32" and fs_acc is None:
            fs_acc = float(nice_ceil(5 * np.abs(analog).max()))
        path = os.path.join(mdir, rec["name"] + ".wav")
        clipped = write_wav(path, np.c_[analog, tach], fs, mc["fmt"], None if mc["fmt"] == "f32" else [fs_acc, 10.0])
        f = rec["fault"]
        ends = pinion_angle(P, R, np.array([0.0, P["dur"]]))
        true_mean = (ends[1] - ends[0]) / (2 * np.pi * P["dur"])
        e_file = rises[(rises >= 0) & (rises < P["dur"])]
        truth = {
            "file": os.path.abspath(path),
            "machine": P["name"],
            "zp": P["zp"],
            "zw": P["zw"],
            "fs": float(fs),
            "format": mc["fmt"],
            "sidecar": mc["fmt"] == "f32",
            "nominal_rpm": P["nominal_rpm"],
            "nominal_speed_hz": P["nominal_rpm"] / 60.0,
            "true_mean_speed_hz": float(true_mean),
            "speed_fluctuation": float(P["speed_fluct"]),
            "load_fluctuation": float(P["load_fluct"]),
            "noise_rel": float(np.std(noise) / np.std(vib)),
            "contact_ratio": float(mesh.cr),
            "aux_mesh_hz": float(P["aux"]["mesh_hz"]) if P["aux"] else 0.0,
            "fault": None if f is None else f["kind"],
            "severity": None if f is None else float(f["severity"]),
            "gear": None if f is None else f["gear"],
            "tooth": None if f is None else f["tooth"],
            "generator": GENERATOR,
            "seed": rec["seed"],
            "duration_s": n_out / fs,
            "tacho": mc["tach"],
            "first_edge_s": float(e_file[0]),  # mechanical; the file's edges lag by the anti-alias filter's delay
            "tacho_edges_in_file": int(len(e_file)),
            "gear_signal_rms": float(np.std(vib)),
            "mesh_hz_mean": float(true_mean * P["zp"]),
            "full_scale": fs_acc if mc["fmt"] != "f32" else None,
            "clipped_samples": clipped,
            "module_mm": mc["module"],
            "face_width_mm": 1e3 * mc["face"],
            "static_deflection_um": 1e6 * P["N0"] / P["kbar"],
        }
        if f is not None:
            if f["kind"] == "crack":
                truth["crack_depth_mm"] = 1e3 * f["depth"]
            elif f["kind"] == "spall":
                truth.update(spall_length_mm=1e3 * f["length"], spall_width_share=f["width"],
                             spall_dip_um=1e6 * f["dip"])
            elif f["kind"] == "wear":
                truth["wear_depth_um"] = 1e6 * f["depth"]
            elif f["kind"] == "eccentricity":
                truth["eccentricity_um"] = 1e6 * f["ecc"]
        write_json(path[:-4] + ".truth.json", truth)
        if mc["fmt"] == "f32":
            write_json(path + ".json", sidecar(path, P, n_out, rec["seed"]))
    log("%s: done in %.0f s" % (P["name"], time.time() - t_begin))
    return P["name"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="/tmp/fourth")
    ap.add_argument("--jobs", type=int, default=2, help="processes (at most 2)")
    ap.add_argument("--machines", default="", help="e.g. m30,m33 (default: all five)")
    a = ap.parse_args()
    ms = [m for m in MACHINES if not a.machines or "m%d" % m["idx"] in a.machines.split(",")]
    ms.sort(key=lambda m: -m["fs"] * m["dur"])
    os.makedirs(a.out, exist_ok=True)
    with ProcessPoolExecutor(max(1, min(a.jobs, 2))) as ex:
        for name in ex.map(make_machine, ms, [a.out] * len(ms)):
            print(name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
