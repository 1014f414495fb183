"""gearvib from Python: periodic gear vibration (simulate, stability) and recording diagnosis.

The same core as the ``gearvib`` command: results are the dictionaries ``--json`` prints, plus numpy
arrays. Bad input raises ``ValueError`` with the CLI's one-line message; a result that cannot be trusted
raises ``GearvibError``. Every call releases the GIL while it computes.
"""

from __future__ import annotations

import json
import os
from typing import Any, Iterable, Optional, Sequence, Tuple, Union

import numpy as np

from . import _gearvib
from ._gearvib import GearvibError

__all__ = [
    "GearvibError",
    "simulate",
    "stability",
    "sweep",
    "diagnose",
    "identify",
    "read_recording",
    "write_recording",
]

SceneLike = Union[dict, str, "os.PathLike[str]"]


def _scene_text(scene: SceneLike) -> Tuple[str, str]:
    """(JSON text, name for messages) of a dict, a JSON string or a path."""
    if isinstance(scene, dict):
        return json.dumps(scene), str(scene.get("name", "scene"))
    text = os.fspath(scene)
    if text.lstrip().startswith("{"):
        return text, "scene"
    try:
        with open(text, encoding="utf-8") as f:
            return f.read(), text
    except OSError as e:
        raise ValueError(f"{text}: {e.strerror}") from None


def simulate(scene: SceneLike) -> dict:
    """Periodic steady state of a scene (dict, JSON string or path).

    Returns the ``simulate --json`` dictionary plus numpy arrays: ``time_s`` (one period, s),
    ``output`` (the output quantity over that period, in the scene's output unit, e.g. m/s for dq/dt),
    ``order`` and ``amplitude`` (one-sided amplitude spectrum by order of the base rotation).
    """
    text, name = _scene_text(scene)
    summary, samples, period = _gearvib.simulate(text, name)
    out = json.loads(summary)
    out["time_s"] = np.arange(len(samples)) * (period / len(samples))
    out["output"] = samples
    out["order"] = np.array([line["order"] for line in out["orders"]])
    out["amplitude"] = np.array([line["amplitude"] for line in out["orders"]])
    return out


def stability(scene: SceneLike) -> dict:
    """Floquet multipliers of a scene: the ``stability --json`` dictionary."""
    text, name = _scene_text(scene)
    return json.loads(_gearvib.stability(text, name))


def sweep(scene: SceneLike, param: str, values: Iterable[float]) -> dict:
    """Floquet analysis and line amplitudes of a scene at each of ``values`` of one parameter.

    ``param``: ``speed`` (rev/min), ``damping`` (ratio), ``load`` (static deflection in m for the gear pair,
    N for the press), or a dotted path of a numeric scene field such as ``gear_pair.damping_ratio``.
    Returns the ``sweep --json`` dictionary (``points``: value, rho_max, stable, trusted, lines, error) plus
    numpy arrays ``value``, ``rho_max`` (NaN where a point failed) and ``stable`` (bool).
    """
    text, name = _scene_text(scene)
    # the limit is checked while reading: an endless or huge iterable is refused at its limit, not read whole
    taken = []
    for v in values:
        if len(taken) == _gearvib.MAX_SWEEP_VALUES:
            raise ValueError(f"sweep: more than {_gearvib.MAX_SWEEP_VALUES} values; give fewer")
        taken.append(float(v))
    out = json.loads(_gearvib.sweep(text, name, param, taken))
    points = out["points"]
    out["value"] = np.array([p["value"] for p in points])
    out["rho_max"] = np.array([np.nan if p["rho_max"] is None else p["rho_max"] for p in points])
    out["stable"] = np.array([bool(p["stable"]) for p in points])
    return out


def diagnose(
    samples: Union[np.ndarray, str, "os.PathLike[str]", Sequence[Any]],
    fs: Optional[float] = None,
    *,
    rpm: Optional[float] = None,
    teeth: Optional[Tuple[int, int]] = None,
    tacho: Optional[int] = None,
    channel: Optional[int] = None,
    unit: Optional[str] = None,
    baseline: Union[None, str, "os.PathLike[str]", Iterable[Union[str, "os.PathLike[str]"]]] = None,
    arrays: bool = True,
    profile: Union[None, str, "os.PathLike[str]"] = None,
    same_load: bool = False,
    fs_unknown: bool = False,
    speed_tolerance: float = 0.05,
    pulses_per_rev: int = 1,
    block_revs: Optional[int] = None,
    sensitivity: Optional[float] = None,
    machine: Union[None, str, "os.PathLike[str]"] = None,
) -> Union[dict, list]:
    """Diagnose recordings: a numpy array (1-D, or channels x samples; float32 or float64, any layout) at
    ``fs`` Hz, a WAV/CSV path, a directory (its .wav and .csv recordings in name order), or a list of them
    (then a list of results, in order, a directory's recordings in its place; a directory alone gives a list).

    ``rpm``: pinion speed in rev/min (estimated when absent); ``teeth``: (pinion, wheel); ``tacho``: the
    1-based tachometer channel; ``channel``: analyse only this 1-based channel; ``unit``: the samples'
    physical unit; ``baseline``: healthy recordings of the same machine (paths or directories);
    ``profile``: a healthy profile written by :func:`learn` (its settings replace rpm, teeth, tacho, channel
    and unit, and its reference replaces a baseline); ``same_load``: the baseline or profile was recorded at
    the recordings' load and speed, so a single baseline file's limits keep no allowance for a neighbouring
    load (``diagnose --same-load``); ``fs_unknown``: no sample rate is known (a CSV without a time column),
    so the recording is analysed in orders of its estimated shaft period (``diagnose --fs-unknown``);
    ``speed_tolerance``: relative window the mesh line is sought in around ``rpm`` (``--speed-tolerance``,
    0 to 0.2); ``pulses_per_rev``: tachometer pulses per revolution; ``block_revs``: revolutions per block
    of the statistical baseline (2 to 10000; default 8, fewer for a short baseline); ``sensitivity``:
    recorded value per physical unit (the samples are divided by it); ``machine``: a machine file
    (``--machine``: several stages or a planetary one; not with ``teeth``). A profile replaces
    ``speed_tolerance``, ``pulses_per_rev``, ``block_revs`` and ``machine`` as it replaces ``rpm`` and
    ``teeth``; ``sensitivity``, like ``unit``, still describes the recording's own file.
    Returns the ``diagnose --json`` dictionary (verdict, indicators, speed profile, ...) with, unless
    ``arrays`` is False, numpy arrays: ``spectra`` (per channel: ``frequency_hz`` [Hz], ``amplitude`` [unit]),
    in each entry of ``gears`` the ``tsa``, ``residual`` and ``difference`` signals over one revolution
    [unit] and the TSA's ``order_amplitude`` [unit] by order of that shaft, in ``envelope`` its spectrum
    (``order``, ``amplitude`` [unit^2]) and in ``cepstrum`` its ``quefrency_s`` [s] and ``value``.
    """
    many = isinstance(samples, (list, tuple))
    items = list(samples) if many else [samples]
    paths = [os.fspath(x) for x in items if isinstance(x, (str, os.PathLike))]
    data = [x for x in items if not isinstance(x, (str, os.PathLike))]
    data = [x if isinstance(x, np.ndarray) else np.asarray(x, dtype=np.float64) for x in data]
    if baseline is None:
        base = []
    elif isinstance(baseline, (str, os.PathLike)):
        base = [os.fspath(baseline)]
    else:
        base = [os.fspath(b) for b in baseline]
    if profile is not None and base:
        raise ValueError("baseline and profile: give one (a profile is a learned baseline)")
    prof = os.fspath(profile) if profile is not None else None
    if same_load and not base and prof is None:
        raise ValueError("same_load needs a baseline or a profile: it says where the baseline was recorded")
    teeth_pair = tuple(teeth) if teeth else None
    more = _more(speed_tolerance, pulses_per_rev, block_revs, sensitivity, machine)
    args = (paths, data, fs, rpm, teeth_pair, tacho, channel, unit, base, prof, bool(same_load), bool(fs_unknown), more)
    raw = _gearvib.diagnose(*args)
    # files come back first (a directory as all its recordings, in name order), then arrays: restore the
    # order given, a directory expanded in its place
    n_files = len(raw) - len(data)
    files, arrs = raw[:n_files], iter(raw[n_files:])
    out, at = [], 0
    for x in items:
        if not isinstance(x, (str, os.PathLike)):
            out.append(_with_arrays(*next(arrs), arrays))
        elif os.path.isdir(x):
            inside = os.path.join(os.fspath(x), "")
            while at < n_files and json.loads(files[at][0])["file"].startswith(inside):
                out.append(_with_arrays(*files[at], arrays))
                at += 1
        else:
            out.append(_with_arrays(*files[at], arrays))
            at += 1
    return out if many or len(out) != 1 or any(isinstance(x, (str, os.PathLike)) and os.path.isdir(x) for x in items) else out[0]


def _with_arrays(text: str, curves: dict, arrays: bool) -> dict:
    """The diagnosis dictionary of ``text`` with the numpy curves put where they belong."""
    d = json.loads(text)
    if not arrays:
        return d
    d["spectra"] = curves["spectra"]
    for gear, c in zip(d["gears"], curves["gears"]):
        gear.update(c)
    for key in ("envelope", "cepstrum"):
        if d.get(key) is not None and curves[key] is not None:
            d[key].update(curves[key])
    return d


def identify(
    recording: Union[str, "os.PathLike[str]"],
    scene: Union[str, "os.PathLike[str]"],
    *,
    pinion_orders: int = 6,
    wheel_orders: int = 0,
    faults: Iterable[str] = (),
    mesh_harmonics: Optional[int] = None,
    pit_width: float = 0.5,
    channel: Optional[int] = None,
    tacho: Optional[int] = None,
    quantity: Optional[str] = None,
) -> dict:
    """Fit the gear pair of ``scene`` to a WAV/CSV ``recording``: the ``identify --json`` dictionary.

    ``pinion_orders`` / ``wheel_orders``: error orders fitted (below half the teeth); ``faults``: local
    faults searched on every tooth, "crack" and/or "pit"; ``pit_width``: pit width in tooth pitches;
    ``channel`` / ``tacho``: 1-based vibration and pinion tachometer channels; ``quantity``:
    "acceleration", "velocity" or "displacement". Amplitudes of ``pinion_errors`` are in m, phases in rad.
    """
    return json.loads(
        _gearvib.identify(
            os.fspath(recording),
            os.fspath(scene),
            pinion_orders,
            wheel_orders,
            list(faults),
            mesh_harmonics,
            pit_width,
            channel,
            tacho,
            quantity,
        )
    )


def read_recording(path: Union[str, "os.PathLike[str]"]) -> dict:
    """A WAV or CSV recording: ``samples`` (float32, channels x samples, in the file's physical unit when
    it has a sidecar or is float/CSV), ``fs`` (Hz or None), ``names`` and ``units`` per channel."""
    samples, fs, names, units = _gearvib.read_recording(os.fspath(path))
    return {"samples": samples, "fs": fs, "names": names, "units": units}


def write_recording(
    path: Union[str, "os.PathLike[str]"],
    samples: np.ndarray,
    fs: float,
    *,
    names: Optional[Sequence[str]] = None,
    units: Optional[Sequence[str]] = None,
) -> None:
    """Write ``samples`` (1-D, or channels x samples; float32 or float64) at ``fs`` Hz to a WAV (float32, a
    whole number of Hz, with a sidecar ``path.json`` holding the channel ``names`` and ``units``) or a CSV
    (a ``time_s`` column and "name [unit]" headers), atomically. ``read_recording`` gives them back."""
    _gearvib.write_recording(
        os.fspath(path),
        np.asarray(samples),
        float(fs),
        None if names is None else list(names),
        None if units is None else list(units),
    )


def _number(name, value):
    """``value`` as a float, or ValueError naming ``name``."""
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name}: {value!r} is not a number") from None


def _count(name, value, least, most):
    """``value`` as a whole number from ``least`` to ``most``, or ValueError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name}: {value!r} is not a whole number")
    if not least <= int(value) <= most:
        raise ValueError(f"{name}: must be {least} to {most}, got {value}")
    return int(value)


def _more(speed_tolerance, pulses_per_rev, block_revs, sensitivity, machine):
    """The settings beyond the common ones, as the extension takes them (a value that is not one raises
    ValueError naming its keyword; the ranges are checked there, as the command checks its flags)."""
    if machine is not None and not isinstance(machine, (str, os.PathLike)):
        raise ValueError(f"machine: {machine!r} is not a path of a machine file")
    return (
        _number("speed_tolerance", speed_tolerance),
        _count("pulses_per_rev", pulses_per_rev, 1, 10_000),
        None if block_revs is None else _count("block_revs", block_revs, 2, 10_000),
        None if sensitivity is None else _number("sensitivity", sensitivity),
        None if machine is None else os.fspath(machine),
    )


def learn(
    healthy: Union[str, "os.PathLike[str]", Iterable[Union[str, "os.PathLike[str]"]]],
    output: Union[str, "os.PathLike[str]"],
    fs: Optional[float] = None,
    *,
    rpm: Optional[float] = None,
    teeth: Optional[Tuple[int, int]] = None,
    tacho: Optional[int] = None,
    channel: Optional[int] = None,
    unit: Optional[str] = None,
    fs_unknown: bool = False,
    speed_tolerance: float = 0.05,
    pulses_per_rev: int = 1,
    block_revs: Optional[int] = None,
    sensitivity: Optional[float] = None,
    machine: Union[None, str, "os.PathLike[str]"] = None,
) -> dict:
    """Learn a healthy profile from healthy recordings of one machine (paths or directories) and write it to
    ``output`` (``gearvib learn ... -o output``); returns the profile as a dictionary. Pass ``output`` as
    ``profile=`` to :func:`diagnose` to judge recordings against it with exactly its settings. ``fs_unknown``:
    no sample rate is known (``learn --fs-unknown``); the profile keeps it, as it keeps
    ``speed_tolerance``, ``pulses_per_rev``, ``block_revs``, ``sensitivity`` and ``machine`` (see
    :func:`diagnose`)."""
    paths = [os.fspath(healthy)] if isinstance(healthy, (str, os.PathLike)) else [os.fspath(h) for h in healthy]
    teeth_pair = tuple(teeth) if teeth else None
    more = _more(speed_tolerance, pulses_per_rev, block_revs, sensitivity, machine)
    text = _gearvib.learn(paths, os.fspath(output), fs, rpm, teeth_pair, tacho, channel, unit, bool(fs_unknown), more)
    return json.loads(text)
