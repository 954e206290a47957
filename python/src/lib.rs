//! The `fxshade` Python module: a unit's bit-exact model on numpy arrays.
//!
//! ```python
//! import numpy as np, fxshade
//! u = fxshade.Unit("normalize", set={"normalize.method": "linear"})
//! out, flags = u.eval(np.array([[9000, -12000, 3000]]))   # int64 codes
//! ref = u.reference(u.input_values(codes))                 # f64 reference
//! ```
//!
//! `Unit(name, config=None, toml=None, set=None)`: the configuration is the
//! embedded default, the TOML file `config`, or the TOML text `toml`, then
//! the overrides `set` (a dict `{key: value}` or a list of `"key=value"`
//! strings, as `--set`), validated with the command line's messages
//! (`ValueError`). `eval(codes)` takes an integer array of shape `(n, I)`
//! (or one row of `I`), `I = len(u.inputs)`, and returns `(outputs, flags)`:
//! `int64` codes of shape `(n, O)` and `uint64` flag words of shape `(n,)`
//! (the RTL's `ovf_o`: stage `k` of `u.flags` is bit `F-1-k`). A code
//! outside its port's format raises `ValueError`; nothing is wrapped. The
//! evaluation releases the GIL. Results are the vector files' expected
//! values bit for bit.

use fxshade_model::rtl::unit_model::{ConfigSource, UnitModel};
use fxshade_model::vectors::Field;
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArrayDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// What `eval` returns: output codes `(n, O)` and flag words `(n,)`.
type Evaluated<'py> = (Bound<'py, PyArray2<i64>>, Bound<'py, PyArray1<u64>>);

/// One unit's bit-exact model for one configuration.
#[pyclass(frozen, module = "fxshade")]
struct Unit {
    model: UnitModel,
}

fn port_dict<'py>(py: Python<'py>, f: &Field, group: Option<&str>) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("name", &f.name)?;
    d.set_item("format", f.format.to_string())?;
    d.set_item("signed", f.format.signed())?;
    d.set_item("width", f.format.width())?;
    d.set_item("frac", f.format.frac())?;
    d.set_item("int_bits", f.format.int_bits())?;
    d.set_item("min_code", f.format.min_code() as i64)?;
    d.set_item("max_code", f.format.max_code() as i64)?;
    d.set_item("group", group.unwrap_or(""))?;
    Ok(d)
}

/// `x` as a numpy array of `dtype` (`"int64"`, `"float64"`): any array or
/// sequence numpy casts to it without loss (`casting="safe"`: int32, uint8
/// or bool to int64, any integer or float32 to float64); anything else is a
/// `TypeError` naming the dtype wanted.
fn as_array<'py, T: numpy::Element>(
    x: &Bound<'py, PyAny>,
    dtype: &str,
    what: &str,
) -> PyResult<PyReadonlyArrayDyn<'py, T>> {
    let py = x.py();
    let np = py.import("numpy")?;
    let a = np.call_method1("asarray", (x,))?;
    let kw = PyDict::new(py);
    kw.set_item("casting", "safe")?;
    let a = a.call_method("astype", (dtype,), Some(&kw)).map_err(|e| {
        pyo3::exceptions::PyTypeError::new_err(format!(
            "{what}: an array numpy can cast to {dtype} without loss ({e})"
        ))
    })?;
    a.extract::<PyReadonlyArrayDyn<'py, T>>()
}

/// An `(n, k)` array of `T` from a 1-D row or a 2-D array.
fn rows<T: numpy::Element + Copy>(
    a: &PyReadonlyArrayDyn<'_, T>,
    k: usize,
    what: &str,
) -> PyResult<(usize, Vec<T>)> {
    let v = a.as_array();
    let (n, cols) = match v.ndim() {
        1 => (1, v.len()),
        2 => (v.shape()[0], v.shape()[1]),
        d => {
            return Err(PyValueError::new_err(format!(
                "{what}: a 1-D row or a 2-D array of rows, not {d}-D"
            )))
        }
    };
    if cols != k {
        return Err(PyValueError::new_err(format!(
            "{what}: rows of {k} values (one per port), not {cols}"
        )));
    }
    Ok((n, v.iter().copied().collect()))
}

fn overrides(set: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<String>> {
    let Some(set) = set else {
        return Ok(Vec::new());
    };
    if let Ok(d) = set.downcast::<PyDict>() {
        let mut out = Vec::new();
        for (k, v) in d.iter() {
            let k: String = k.extract()?;
            let v = if let Ok(b) = v.extract::<bool>() {
                b.to_string()
            } else if let Ok(s) = v.extract::<String>() {
                s
            } else {
                v.str()?.to_string()
            };
            out.push(format!("{k}={v}"));
        }
        Ok(out)
    } else if let Ok(l) = set.downcast::<PyList>() {
        l.iter().map(|s| s.extract::<String>()).collect()
    } else {
        Err(PyValueError::new_err(
            "set: a dict {key: value} or a list of \"key=value\" strings",
        ))
    }
}

#[pymethods]
impl Unit {
    /// Open a unit (`fxshade rtl list` names them) for a configuration.
    #[new]
    #[pyo3(signature = (name, config=None, toml=None, set=None))]
    fn new(
        py: Python<'_>,
        name: &str,
        config: Option<std::path::PathBuf>,
        toml: Option<&str>,
        set: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let sets = overrides(set)?;
        if toml.is_some() && config.is_some() {
            return Err(PyValueError::new_err(
                "give the configuration as config (a file) or as toml (text), not both",
            ));
        }
        let path_name = config.as_ref().map(|p| p.display().to_string());
        let model = py
            .allow_threads(|| {
                let source = match (toml, &config) {
                    (Some(t), _) => ConfigSource::Text {
                        text: t,
                        name: path_name.as_deref().unwrap_or("<toml text>"),
                    },
                    (None, Some(p)) => ConfigSource::File(p),
                    (None, None) => ConfigSource::Default,
                };
                UnitModel::open(name, source, &sets)
            })
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Unit { model })
    }

    /// The unit's name.
    #[getter]
    fn name(&self) -> &'static str {
        self.model.unit.name
    }

    /// The emitted module's name.
    #[getter]
    fn module(&self) -> String {
        self.model.module().to_string()
    }

    /// Cycles from an input transfer to its output in the emitted module.
    #[getter]
    fn latency(&self) -> u32 {
        self.model.latency()
    }

    /// Input ports, in row order: dicts of name, format, signed, width,
    /// frac, int_bits, min_code, max_code and group (the set-up port that
    /// loads it, or "").
    #[getter]
    fn inputs<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.model
            .inputs()
            .iter()
            .map(|f| port_dict(py, f, self.model.setup_group(&f.name)))
            .collect()
    }

    /// Output ports, in column order (the flag word apart).
    #[getter]
    fn outputs<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.model
            .outputs()
            .iter()
            .map(|f| port_dict(py, f, None))
            .collect()
    }

    /// The overflow-flag stage ids, flag 0 first (bit F-1-k of a flag word).
    #[getter]
    fn flags(&self) -> Vec<String> {
        self.model.flags().to_vec()
    }

    /// The one-line port layout generated callers compare.
    #[getter]
    fn layout(&self) -> String {
        self.model.layout()
    }

    /// The unit's manifest (the vector manifest's description) as JSON text.
    fn manifest_json(&self) -> String {
        self.model.manifest().to_string()
    }

    /// Evaluate rows of input codes: `(outputs int64 (n, O), flags uint64 (n,))`.
    fn eval<'py>(&self, py: Python<'py>, codes: &Bound<'py, PyAny>) -> PyResult<Evaluated<'py>> {
        let codes = as_array::<i64>(codes, "int64", "codes")?;
        let (n, ins) = rows(&codes, self.model.inputs().len(), "codes")?;
        let no = self.model.outputs().len();
        let (outs, flags) = py
            .allow_threads(|| {
                let mut outs = vec![0i64; n * no];
                let mut flags = vec![0u64; n];
                self.model
                    .eval(n, &ins, &mut outs, Some(&mut flags))
                    .map(|_| (outs, flags))
            })
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let outs = Array2::from_shape_vec((n, no), outs).expect("n × O values");
        Ok((
            outs.into_pyarray(py),
            Array1::from_vec(flags).into_pyarray(py),
        ))
    }

    /// The f64 reference of rows of input *values* (shape (n, I)): the
    /// datapath in real arithmetic, every quantization the identity and
    /// every table its exact function; float64 (n, O).
    fn reference<'py>(
        &self,
        py: Python<'py>,
        values: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let values = as_array::<f64>(values, "float64", "values")?;
        let (n, ins) = rows(&values, self.model.inputs().len(), "values")?;
        let no = self.model.outputs().len();
        let outs = py
            .allow_threads(|| {
                let mut outs = vec![0f64; n * no];
                self.model.reference(n, &ins, &mut outs).map(|_| outs)
            })
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Array2::from_shape_vec((n, no), outs)
            .expect("n × O values")
            .into_pyarray(py))
    }

    /// Input codes as real values: `code · 2^-frac` per column.
    fn input_values<'py>(
        &self,
        py: Python<'py>,
        codes: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        values_of(py, self.model.inputs(), &as_array(codes, "int64", "codes")?)
    }

    /// Output codes as real values: `code · 2^-frac` per column.
    fn output_values<'py>(
        &self,
        py: Python<'py>,
        codes: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        values_of(
            py,
            self.model.outputs(),
            &as_array(codes, "int64", "codes")?,
        )
    }

    /// Real input values as codes of the input ports' formats, rounded to
    /// nearest with ties to even; a value whose rounded code lies outside
    /// its format raises ValueError (nothing saturates silently).
    fn input_codes<'py>(
        &self,
        py: Python<'py>,
        values: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let values = as_array::<f64>(values, "float64", "values")?;
        let fields = self.model.inputs();
        let (n, v) = rows(&values, fields.len(), "values")?;
        let k = fields.len();
        let mut out = vec![0i64; n * k];
        for i in 0..n {
            for (j, f) in fields.iter().enumerate() {
                out[i * k + j] = f
                    .format
                    .from_f64(v[i * k + j], fxshade_model::quantize::Rounding::HalfEven)
                    .map_err(|e| PyValueError::new_err(format!("row {i}, input {}: {e}", f.name)))?
                    as i64;
            }
        }
        Ok(Array2::from_shape_vec((n, k), out)
            .expect("n × I codes")
            .into_pyarray(py))
    }

    fn __repr__(&self) -> String {
        format!(
            "fxshade.Unit({:?}, module={:?}, inputs={}, outputs={}, flags={})",
            self.model.unit.name,
            self.model.module(),
            self.model.inputs().len(),
            self.model.outputs().len(),
            self.model.flags().len()
        )
    }
}

fn values_of<'py>(
    py: Python<'py>,
    fields: &[Field],
    codes: &PyReadonlyArrayDyn<'py, i64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let (n, c) = rows(codes, fields.len(), "codes")?;
    let k = fields.len();
    let mut v = Vec::with_capacity(c.len());
    for (i, &x) in c.iter().enumerate() {
        let f = &fields[i % k];
        if !f.format.contains(x as i128) {
            return Err(PyValueError::new_err(format!(
                "row {}: code {x} of {} lies outside {} (codes {}..={})",
                i / k,
                f.name,
                f.format,
                f.format.min_code(),
                f.format.max_code()
            )));
        }
        v.push(f.format.to_f64(x as i128));
    }
    Ok(Array2::from_shape_vec((n, k), v)
        .expect("n × k values")
        .into_pyarray(py))
}

/// The names of the units with RTL.
#[pyfunction]
fn units() -> Vec<&'static str> {
    fxshade_model::rtl::units::all().map(|u| u.name).collect()
}

/// fxshade's bit-exact model: `Unit`, `units()`, `ABI_VERSION`.
#[pymodule]
fn fxshade(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Unit>()?;
    m.add_function(wrap_pyfunction!(units, m)?)?;
    m.add("ABI_VERSION", fxshade_model::rtl::unit_model::ABI_VERSION)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
