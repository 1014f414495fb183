//! Python bindings of gearvib (module `gearvib._gearvib`): thin calls into the library's jobs, never the
//! CLI. Results cross as the same JSON the CLI prints with `--json` plus numpy arrays; the pure-Python
//! package `gearvib` wraps them. Every call releases the GIL while it computes.

use gearvib::io::Recording;
use gearvib::jobs::diagnose::{BaselineLoad, DiagnoseJob, Options, Prepared};
use gearvib::scene::Scene;
use numpy::ndarray::Axis;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::borrow::Cow;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

create_exception!(_gearvib, GearvibError, PyException, "A result gearvib cannot trust or could not compute.");

/// Bad input (scene, data, a value that does not fit) raises `ValueError`; the rest `GearvibError`. The
/// message is the CLI's one line.
fn to_py(e: gearvib::Error) -> PyErr {
    let msg = e.to_string();
    match e {
        gearvib::Error::Scene(_) | gearvib::Error::Data(_) | gearvib::Error::Signal(_) | gearvib::Error::Cli(_) => {
            PyValueError::new_err(msg)
        }
        gearvib::Error::Job(gearvib::jobs::JobError::Untrusted { .. }) | gearvib::Error::Solver(_) => {
            GearvibError::new_err(msg)
        }
        _ => PyValueError::new_err(msg),
    }
}

fn scene_from(text: &str, name: &str) -> Result<Scene, gearvib::Error> {
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| {
        gearvib::Error::from(gearvib::jobs::JobError::Input { file: name.into(), message: format!("not JSON: {e}") })
    })?;
    Ok(Scene::from_value(value, name)?)
}

/// simulate(scene_json, name) -> (summary_json, period_samples, period_s): the `simulate --json` summary,
/// the output quantity over one period at equally spaced times from 0, and the period in s.
#[pyfunction]
fn simulate(py: Python<'_>, scene_json: &str, name: &str) -> PyResult<(String, Py<PyArray1<f64>>, f64)> {
    let (text, samples, period) = py
        .detach(|| {
            let scene = scene_from(scene_json, name)?;
            let (sim, summary) = gearvib::jobs::simulate::summarize(&scene)?;
            let text = serde_json::to_string(&summary).unwrap_or_default();
            Ok::<_, gearvib::Error>((text, sim.period_samples, sim.steady.period_s))
        })
        .map_err(to_py)?;
    Ok((text, samples.into_pyarray(py).unbind(), period))
}

/// stability(scene_json, name) -> summary_json (`stability --json`).
#[pyfunction]
fn stability(py: Python<'_>, scene_json: &str, name: &str) -> PyResult<String> {
    py.detach(|| {
        let scene = scene_from(scene_json, name)?;
        let (_, summary) = gearvib::jobs::simulate::stability_of(&scene)?;
        Ok(serde_json::to_string(&summary).unwrap_or_default())
    })
    .map_err(to_py)
}

/// sweep(scene_json, name, param, values) -> summary_json (`sweep --json`): Floquet analysis and line
/// amplitudes at each value of the parameter (an alias such as `speed`, or a dotted path of the scene).
#[pyfunction]
fn sweep(py: Python<'_>, scene_json: &str, name: &str, param: &str, values: Vec<f64>) -> PyResult<String> {
    py.detach(|| {
        use gearvib::jobs::sweep as sw;
        let scene = scene_from(scene_json, name)?;
        let field = sw::resolve(&scene, param)?;
        let quiet = sw::Progress { estimate: &|_| {}, tick: &|| {} };
        let points = sw::sweep_values(&scene, &field, &values, None, &quiet)?;
        let summary = sw::summarize(&scene, &field, points)?;
        Ok(serde_json::to_string(&summary).unwrap_or_default())
    })
    .map_err(to_py)
}

/// write_recording(path, samples, fs, names, units): writes a WAV (float32, whole Hz, with a sidecar
/// naming the channels and units) or a CSV (time column, "name [unit]" headers), atomically.
#[pyfunction]
#[pyo3(signature = (path, samples, fs, names=None, units=None))]
fn write_recording(
    py: Python<'_>,
    path: &str,
    samples: Bound<'_, PyAny>,
    fs: f64,
    names: Option<Vec<String>>,
    units: Option<Vec<String>>,
) -> PyResult<()> {
    let held = held_array(&samples, Some(fs))?;
    let mut rec = recording_of(&held, Some(fs))?;
    let n = rec.channels.len();
    for (what, given, slot) in [("names", names, &mut rec.names), ("units", units, &mut rec.units)] {
        if let Some(v) = given {
            if v.len() != n {
                return Err(PyValueError::new_err(format!("{what}: {} given for {n} channels", v.len())));
            }
            *slot = v;
        }
    }
    py.detach(|| gearvib::io::write_recording(std::path::Path::new(path), &rec)).map_err(|e| to_py(e.into()))
}

/// Diagnosis options from the keyword arguments the Python wrapper passes on.
#[derive(Default)]
struct Kw {
    rpm: Option<f64>,
    teeth: Option<(usize, usize)>,
    tacho: Option<usize>,
    channel: Option<usize>,
    unit: Option<String>,
    /// No sample rate is known: analyse in orders of the estimated shaft period (`--fs-unknown`).
    fs_unknown: bool,
    /// The settings `--speed-tolerance`, `--pulses-per-rev`, `--block-revs`, `--sensitivity` and
    /// `--machine` give the command.
    more: More,
}

/// The keyword arguments beyond the common ones: (speed_tolerance [relative], pulses_per_rev,
/// block_revs, sensitivity [recorded value per physical unit], machine [path of a machine file]).
type More = (f64, usize, Option<usize>, Option<f64>, Option<String>);

/// The options `more` sets, checked as the command line checks its flags (named by the keyword).
fn more_options(k: &Kw, o: &mut Options) -> PyResult<()> {
    let (tolerance, pulses, block_revs, sensitivity, machine) = k.more.clone();
    if !(tolerance.is_finite() && (0.0..=0.2).contains(&tolerance)) {
        return Err(PyValueError::new_err(format!(
            "speed_tolerance: must be between 0 and 0.2 (relative), got {tolerance}"
        )));
    }
    if pulses == 0 {
        return Err(PyValueError::new_err("pulses_per_rev: must be 1 or more"));
    }
    if let Some(r) = block_revs.filter(|r| !(2..=10_000).contains(r)) {
        return Err(PyValueError::new_err(format!("block_revs: must be 2 to 10000, got {r}")));
    }
    if let Some(v) = sensitivity.filter(|v| !(v.is_finite() && *v > 0.0)) {
        return Err(PyValueError::new_err(format!("sensitivity: must be a positive number, got {v}")));
    }
    if machine.is_some() && k.teeth.is_some() {
        return Err(PyValueError::new_err(
            "teeth and machine: the machine file states every stage's teeth (teeth is the one-stage shorthand)",
        ));
    }
    o.speed_tolerance = tolerance;
    o.pulses_per_rev = pulses;
    o.block_revs = block_revs;
    o.sensitivity = sensitivity;
    o.machine = machine
        .map(|m| gearvib::scene::machine::load_machine_file(&m))
        .transpose()
        .map_err(|e| PyValueError::new_err(format!("machine: {e}")))?;
    Ok(())
}

fn options(k: &Kw, fs: Option<f64>) -> Result<Options, gearvib::Error> {
    if fs.is_some() && k.fs_unknown {
        return Err(gearvib::jobs::JobError::Value {
            what: gearvib::jobs::Given::SampleRate,
            message: "fs and fs_unknown: give the sample rate or say it is unknown".into(),
        }
        .into());
    }
    if let Some(r) = k.rpm {
        if !(r.is_finite() && r > 0.0) {
            return Err(gearvib::jobs::JobError::Value {
                what: gearvib::jobs::Given::ShaftSpeed,
                message: format!("{r} is not a positive speed"),
            }
            .into());
        }
    }
    if let Some((a, b)) = k.teeth {
        if a < 3 || b < 3 {
            return Err(gearvib::jobs::JobError::Value {
                what: gearvib::jobs::Given::Teeth,
                message: format!("({a}, {b}): at least 3 teeth each"),
            }
            .into());
        }
    }
    Ok(Options {
        fs_hz: fs,
        fs_unknown: k.fs_unknown,
        shaft_hz: k.rpm.map(|r| r / 60.0),
        teeth: k.teeth,
        tacho_channel: k.tacho,
        channel: k.channel,
        unit: k.unit.clone(),
        // the curves handed to numpy hold every channel's spectrum
        all_spectra: true,
        ..Default::default()
    })
}

/// diagnose(paths, arrays, fs, rpm, teeth, tacho, channel, unit, baseline, profile, same_load, fs_unknown, more) -> list of (`diagnose --json`
/// object as a JSON string, its curves as numpy arrays (see `Curves::into_py`)): files first, then the
/// in-memory recordings (channels x samples, float32 or float64, any layout) named "array 1", "array 2", ...
#[pyfunction]
#[pyo3(signature = (paths, arrays, fs=None, rpm=None, teeth=None, tacho=None, channel=None, unit=None, baseline=Vec::new(), profile=None, same_load=false, fs_unknown=false, more=(0.05, 1, None, None, None)))]
#[allow(clippy::too_many_arguments)]
fn diagnose(
    py: Python<'_>,
    paths: Vec<String>,
    arrays: Vec<Bound<'_, PyAny>>,
    fs: Option<f64>,
    rpm: Option<f64>,
    teeth: Option<(usize, usize)>,
    tacho: Option<usize>,
    channel: Option<usize>,
    unit: Option<String>,
    baseline: Vec<String>,
    profile: Option<String>,
    same_load: bool,
    fs_unknown: bool,
    more: More,
) -> PyResult<Vec<(String, Py<PyDict>)>> {
    // the arrays stay borrowed (read-only) for the whole call: float32 rows that are contiguous are read in
    // place, others are converted once
    let held = arrays.iter().map(|a| held_array(a, fs)).collect::<PyResult<Vec<_>>>()?;
    let mut in_memory = Vec::new();
    for (i, h) in held.iter().enumerate() {
        in_memory.push((PathBuf::from(format!("array {}", i + 1)), recording_of(h, fs)?));
    }
    let kw = Kw { rpm, teeth, tacho, channel, unit, fs_unknown, more };
    let mut job_options = options(&kw, fs).map_err(to_py)?;
    more_options(&kw, &mut job_options)?;
    py.detach(|| {
        let job = DiagnoseJob {
            recordings: paths.iter().map(PathBuf::from).collect(),
            options: job_options,
            baselines: baseline.iter().map(PathBuf::from).collect(),
            profile: profile.map(PathBuf::from),
            in_memory,
            baseline_load: if same_load { BaselineLoad::Same } else { BaselineLoad::Unknown },
            ..Default::default()
        };
        let prepared = prepared_for(&job)?;
        let mut out = Vec::new();
        gearvib::jobs::diagnose::run_streaming_prepared(&job, &prepared, &mut |d| {
            // a recording that fails raises, naming it (the binary's batches report it and go on)
            let d = d.map_err(|f| f.error)?;
            out.push((serde_json::to_string(&d).unwrap_or_default(), Curves::of(d)));
            Ok(())
        })?;
        Ok(out)
    })
    .map_err(to_py)
    .and_then(|all| all.into_iter().map(|(text, curves)| Ok((text, curves.into_py(py)?))).collect())
}

/// learn(paths, output, fs, rpm, teeth, tacho, channel, unit, fs_unknown, more) -> the profile written to `output`, as JSON
/// text (`gearvib learn ... -o output`).
#[pyfunction]
#[pyo3(signature = (paths, output, fs=None, rpm=None, teeth=None, tacho=None, channel=None, unit=None, fs_unknown=false, more=(0.05, 1, None, None, None)))]
#[allow(clippy::too_many_arguments)]
fn learn(
    py: Python<'_>,
    paths: Vec<String>,
    output: String,
    fs: Option<f64>,
    rpm: Option<f64>,
    teeth: Option<(usize, usize)>,
    tacho: Option<usize>,
    channel: Option<usize>,
    unit: Option<String>,
    fs_unknown: bool,
    more: More,
) -> PyResult<String> {
    let kw = Kw { rpm, teeth, tacho, channel, unit, fs_unknown, more };
    let mut options = options(&kw, fs).map_err(to_py)?;
    more_options(&kw, &mut options)?;
    py.detach(|| {
        let job = gearvib::jobs::diagnose::profile::LearnJob {
            healthy: paths.iter().map(PathBuf::from).collect(),
            options,
            output: PathBuf::from(&output),
        };
        gearvib::jobs::diagnose::profile::learn(&job).map(|p| serde_json::to_string(&p).unwrap_or_default())
    })
    .map_err(to_py)
}

/// The curves of a diagnosis that `--json` leaves out, for numpy: amplitude spectra per channel, each
/// gear's TSA with its residual, difference signal and order amplitudes, the envelope spectrum, the cepstrum.
struct Curves {
    spectra: Vec<(usize, Vec<f64>, Vec<f64>)>,
    gears: Vec<[Vec<f64>; 4]>,
    envelope: Option<(Vec<f64>, Vec<f64>)>,
    cepstrum: Option<(f64, Vec<f64>)>,
}

impl Curves {
    fn of(d: gearvib::report::summary::Diagnosis) -> Self {
        let spectra = d.spectra().iter().map(|(c, s)| (*c, s.freqs_hz.clone(), s.values.clone())).collect();
        let gears = d.gears.into_iter().map(|g| [g.tsa, g.residual, g.difference, g.tsa_amplitudes]).collect();
        let envelope = d.envelope.map(|e| (e.orders, e.amplitudes));
        let cepstrum = d.cepstrum.map(|c| (c.dq_s, c.values));
        Self { spectra, gears, envelope, cepstrum }
    }

    /// {"spectra": [{channel, frequency_hz, amplitude}], "gears": [{tsa, residual, difference,
    /// order_amplitude}] (in the order of the JSON's "gears"), "envelope": {order, amplitude} or None,
    /// "cepstrum": {quefrency_s, value} or None}.
    fn into_py(self, py: Python<'_>) -> PyResult<Py<PyDict>> {
        let out = PyDict::new(py);
        let spectra = PyList::empty(py);
        for (c, f, a) in self.spectra {
            let s = PyDict::new(py);
            s.set_item("channel", c)?;
            s.set_item("frequency_hz", f.into_pyarray(py))?;
            s.set_item("amplitude", a.into_pyarray(py))?;
            spectra.append(s)?;
        }
        out.set_item("spectra", spectra)?;
        let gears = PyList::empty(py);
        for [tsa, residual, difference, amplitudes] in self.gears {
            let g = PyDict::new(py);
            g.set_item("tsa", tsa.into_pyarray(py))?;
            g.set_item("residual", residual.into_pyarray(py))?;
            g.set_item("difference", difference.into_pyarray(py))?;
            g.set_item("order_amplitude", amplitudes.into_pyarray(py))?;
            gears.append(g)?;
        }
        out.set_item("gears", gears)?;
        match self.envelope {
            Some((o, a)) => {
                let e = PyDict::new(py);
                e.set_item("order", o.into_pyarray(py))?;
                e.set_item("amplitude", a.into_pyarray(py))?;
                out.set_item("envelope", e)?;
            }
            None => out.set_item("envelope", py.None())?,
        }
        match self.cepstrum {
            Some((dq, v)) => {
                let c = PyDict::new(py);
                let q: Vec<f64> = (0..v.len()).map(|i| i as f64 * dq).collect();
                c.set_item("quefrency_s", q.into_pyarray(py))?;
                c.set_item("value", v.into_pyarray(py))?;
                out.set_item("cepstrum", c)?;
            }
            None => out.set_item("cepstrum", py.None())?,
        }
        Ok(out.unbind())
    }
}

/// The baseline side of the last call, kept per process: a worker that diagnoses one recording per call
/// against the same baseline (a Dask fleet) analyses the baseline once. The key holds the options, the
/// baseline paths and each file's size and modification time, so a changed baseline is prepared anew.
static PREPARED: Mutex<Option<(String, Arc<Prepared>)>> = Mutex::new(None);

fn prepared_for(job: &DiagnoseJob) -> Result<Arc<Prepared>, gearvib::Error> {
    let stamp = |p: &PathBuf| {
        std::fs::metadata(p).map(|m| (m.len(), m.modified().ok())).map_or_else(|e| e.to_string(), |m| format!("{m:?}"))
    };
    let key = format!(
        "{:?}|{:?}|{:?}|{:?}",
        job.options,
        job.baseline_load,
        job.baselines.iter().map(|b| (b.clone(), stamp(b))).collect::<Vec<_>>(),
        job.profile.as_ref().map(|p| (p.clone(), stamp(p)))
    );
    let mut cache = PREPARED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some((k, p)) = cache.as_ref() {
        if *k == key {
            return Ok(Arc::clone(p));
        }
    }
    let p = Arc::new(gearvib::jobs::diagnose::prepare(job)?);
    if !job.baselines.is_empty() || job.profile.is_some() {
        *cache = Some((key, Arc::clone(&p)));
    }
    Ok(p)
}

/// A numpy array held read-only for the length of a call: float32 or float64, channels x samples.
enum Held<'py> {
    F32(PyReadonlyArray2<'py, f32>),
    F64(PyReadonlyArray2<'py, f64>),
}

/// `a` (1-D: one channel; 2-D: channels x samples) borrowed read-only, after the checks that need no data.
fn held_array<'py>(a: &Bound<'py, PyAny>, fs: Option<f64>) -> PyResult<Held<'py>> {
    if !fs.is_some_and(|f| f.is_finite() && f > 0.0) {
        return Err(PyValueError::new_err("fs: a positive sample rate in Hz is needed for an array"));
    }
    let two_d =
        if a.getattr("ndim")?.extract::<usize>()? == 1 { a.call_method1("reshape", (1, -1))? } else { a.clone() };
    if let Ok(x) = two_d.extract::<PyReadonlyArray2<'py, f32>>() {
        Ok(Held::F32(x))
    } else if let Ok(x) = two_d.extract::<PyReadonlyArray2<'py, f64>>() {
        Ok(Held::F64(x))
    } else {
        Err(PyValueError::new_err("samples: a 1-D or 2-D (channels x samples) float32 or float64 array"))
    }
}

/// A held array as a recording at `fs` Hz: float32 rows contiguous in memory (C order, or a 1-D array) are
/// lent without a copy; other layouts and float64 are converted to float32 once.
fn recording_of<'a>(h: &'a Held<'_>, fs: Option<f64>) -> PyResult<Recording<'a>> {
    let channels: Vec<Cow<'a, [f32]>> = match h {
        Held::F32(x) => {
            let view = x.as_array();
            (0..view.nrows())
                .map(|i| {
                    let row = view.index_axis_move(Axis(0), i);
                    match row.to_slice() {
                        Some(s) => Cow::Borrowed(s),
                        None => Cow::Owned(row.iter().copied().collect()),
                    }
                })
                .collect()
        }
        Held::F64(x) => {
            x.as_array().rows().into_iter().map(|row| Cow::Owned(row.iter().map(|&v| v as f32).collect())).collect()
        }
    };
    if channels.is_empty() || channels[0].len() < 2 {
        return Err(PyValueError::new_err("samples: an empty array"));
    }
    if channels.iter().any(|c| c.iter().any(|v| !v.is_finite())) {
        return Err(PyValueError::new_err("samples: NaN or infinite values"));
    }
    let n = channels.len();
    Ok(Recording {
        channels,
        sample_rate_hz: fs,
        names: (1..=n).map(|c| format!("ch{c}")).collect(),
        units: vec![String::new(); n],
        warnings: Vec::new(),
    })
}

/// A recording for Python: samples (float32, channels x samples), sample rate in Hz, names, units.
type PyRecording = (Py<PyArray2<f32>>, Option<f64>, Vec<String>, Vec<String>);

/// read_recording(path) -> (samples float32 channels x samples, fs or None, names, units).
#[pyfunction]
fn read_recording(py: Python<'_>, path: &str) -> PyResult<PyRecording> {
    let rec = py.detach(|| gearvib::io::read_recording(std::path::Path::new(path))).map_err(|e| to_py(e.into()))?;
    let n = rec.channels.iter().map(|c| c.len()).max().unwrap_or(0);
    let flat: Vec<f32> =
        rec.channels.iter().flat_map(|c| c.iter().copied().chain(std::iter::repeat_n(0.0, n - c.len()))).collect();
    let array = numpy::ndarray::Array2::from_shape_vec((rec.channels.len(), n), flat)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok((array.into_pyarray(py).unbind(), rec.sample_rate_hz, rec.names, rec.units))
}

/// identify(recording, scene, pinion_orders, wheel_orders, faults, mesh_harmonics, pit_width, channel,
/// tacho, quantity) -> the `identify --json` object as text.
#[pyfunction]
#[allow(clippy::too_many_arguments)] // the keyword arguments of the Python wrapper, one to one
fn identify(
    py: Python<'_>,
    recording: &str,
    scene: &str,
    pinion_orders: usize,
    wheel_orders: usize,
    faults: Vec<String>,
    mesh_harmonics: Option<usize>,
    pit_width: f64,
    channel: Option<usize>,
    tacho: Option<usize>,
    quantity: Option<String>,
) -> PyResult<String> {
    let faults = faults
        .iter()
        .map(|f| f.parse::<gearvib::jobs::identify::FaultKind>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| PyValueError::new_err(format!("faults: {e}")))?;
    let quantity = quantity
        .map(|q| q.parse::<gearvib::model::Quantity>())
        .transpose()
        .map_err(|e| PyValueError::new_err(format!("quantity: {e}")))?;
    let job = gearvib::jobs::identify::IdentifyJob {
        recording: PathBuf::from(recording),
        scene: PathBuf::from(scene),
        pinion_orders,
        wheel_orders,
        mesh_harmonics,
        faults,
        pit_width_teeth: pit_width,
        channel,
        tacho_channel: tacho,
        fs_hz: None,
        quantity,
        report: None,
    };
    py.detach(|| gearvib::jobs::identify::run(&job).map(|r| serde_json::to_string(&r).unwrap_or_default()))
        .map_err(to_py)
}

/// The compiled part of the `gearvib` package.
#[pymodule]
fn _gearvib(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("GearvibError", m.py().get_type::<GearvibError>())?;
    m.add("MAX_SWEEP_VALUES", gearvib::jobs::sweep::MAX_SWEEP_VALUES)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(stability, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(learn, m)?)?;
    m.add_function(wrap_pyfunction!(read_recording, m)?)?;
    m.add_function(wrap_pyfunction!(write_recording, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    Ok(())
}
