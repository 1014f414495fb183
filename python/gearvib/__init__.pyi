import os
from typing import Any, Iterable, Optional, Sequence, Tuple, Union

import numpy as np

SceneLike = Union[dict, str, os.PathLike[str]]
PathLike = Union[str, os.PathLike[str]]

class GearvibError(Exception):
    """A result gearvib cannot trust (tolerance not met) or could not compute."""

def simulate(scene: SceneLike) -> dict[str, Any]:
    """Periodic steady state: the `simulate --json` keys plus `time_s` [s], `output` [output unit],
    `order` [-] and `amplitude` [output unit] arrays."""

def stability(scene: SceneLike) -> dict[str, Any]:
    """Floquet multipliers: the `stability --json` keys."""

def sweep(scene: SceneLike, param: str, values: Iterable[float]) -> dict[str, Any]:
    """The `sweep --json` keys plus `value` [parameter unit], `rho_max` [-] (NaN where a point failed)
    and `stable` arrays."""

def diagnose(
    samples: Union[np.ndarray, PathLike, Sequence[Any]],
    fs: Optional[float] = ...,
    *,
    rpm: Optional[float] = ...,
    teeth: Optional[Tuple[int, int]] = ...,
    tacho: Optional[int] = ...,
    channel: Optional[int] = ...,
    unit: Optional[str] = ...,
    baseline: Union[None, PathLike, Iterable[PathLike]] = ...,
    arrays: bool = ...,
    profile: Optional[PathLike] = ...,
    same_load: bool = ...,
    fs_unknown: bool = ...,
    speed_tolerance: float = ...,
    pulses_per_rev: int = ...,
    block_revs: Optional[int] = ...,
    sensitivity: Optional[float] = ...,
    machine: Optional[PathLike] = ...,
) -> Union[dict[str, Any], list[dict[str, Any]]]:
    """Diagnosis of an array at `fs` [Hz] or a WAV/CSV path (or a list): the `diagnose --json` keys plus
    numpy arrays (unless `arrays` is False): `spectra` [Hz, unit], per gear `tsa`, `residual`,
    `difference` [unit] and `order_amplitude` [unit], `envelope` `order`/`amplitude`, `cepstrum`."""

def identify(
    recording: PathLike,
    scene: PathLike,
    *,
    pinion_orders: int = ...,
    wheel_orders: int = ...,
    faults: Iterable[str] = ...,
    mesh_harmonics: Optional[int] = ...,
    pit_width: float = ...,
    channel: Optional[int] = ...,
    tacho: Optional[int] = ...,
    quantity: Optional[str] = ...,
) -> dict[str, Any]:
    """Tooth errors [m, rad], per-tooth deviation [m], path gains and a local fault: the `identify --json` keys."""

def read_recording(path: PathLike) -> dict[str, Any]:
    """`samples` (float32, channels x samples), `fs` [Hz] or None, `names`, `units`."""

def write_recording(
    path: PathLike,
    samples: np.ndarray,
    fs: float,
    *,
    names: Optional[Sequence[str]] = ...,
    units: Optional[Sequence[str]] = ...,
) -> None:
    """Writes channels x samples at `fs` [Hz] to a WAV (float32, with a sidecar of names and units) or CSV."""

def learn(
    healthy: Union[PathLike, Iterable[PathLike]],
    output: PathLike,
    fs: Optional[float] = ...,
    *,
    rpm: Optional[float] = ...,
    teeth: Optional[Tuple[int, int]] = ...,
    tacho: Optional[int] = ...,
    channel: Optional[int] = ...,
    unit: Optional[str] = ...,
    fs_unknown: bool = ...,
    speed_tolerance: float = ...,
    pulses_per_rev: int = ...,
    block_revs: Optional[int] = ...,
    sensitivity: Optional[float] = ...,
    machine: Optional[PathLike] = ...,
) -> dict[str, Any]:
    """The healthy profile learned from `healthy` and written to `output` (the `learn` JSON)."""
