//! fxshade's C ABI: the bit-exact model of every unit with RTL, for C, C++,
//! SystemVerilog (DPI-C) and anything else that calls C.
//!
//! Open a unit for a configuration with [`fxs_open`] (the embedded
//! default, TOML text or a file, plus `--set`-style overrides; the same
//! validation and messages as the command line), query its ports
//! ([`fxs_input`], [`fxs_output`]), its overflow-flag stage ids
//! ([`fxs_flag_stage`]), latency and manifest, and evaluate rows of input
//! codes with [`fxs_eval`]. Every call catches panics; a failing call
//! returns `NULL` or `-1` and [`fxs_last_error`] says why.
//!
//! Codes are `int64_t`: a signed port's code is its two's-complement value,
//! an unsigned port's its value. An input code outside its port's format
//! is an error (nothing is evaluated), never wrapped. The flag word of a
//! row is the RTL's `ovf_o` and the vector files' `ovf` field: with `F`
//! flag stages, stage `k` ([`fxs_flag_stage`]`(u, k)`) is bit `F-1-k`.
//! Pipeline tops take every input with every row, the set-up (frame,
//! triangle) fields included, as the vector files do; [`FxsPort::group`]
//! names a field's set-up port.
//!
//! The `fxs_dpi_*` functions are the same calls in the shapes DPI-C
//! passes (`chandle`, `string`, sized `longint` arrays): the generated
//! `<module>_dpi_pkg.sv` imports them.

use std::cell::RefCell;
use std::ffi::{c_char, c_int, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use fxshade_model::rtl::unit_model::{ConfigSource, ModelError, UnitModel, ABI_VERSION};

/// An open unit (opaque).
pub struct FxsUnit {
    model: UnitModel,
    /// Port names, formats and groups as C strings, inputs then outputs.
    names: Vec<CString>,
    formats: Vec<CString>,
    groups: Vec<CString>,
    flags: Vec<CString>,
    module: CString,
    manifest: CString,
    layout: CString,
}

/// One port of an open unit. The strings belong to the unit and stay
/// valid until [`fxs_close`].
#[repr(C)]
pub struct FxsPort {
    /// Field name (the module's port is `<name>_i` or `<name>_o`).
    pub name: *const c_char,
    /// Format, `I<int>F<frac>` or `U<int>F<frac>`.
    pub format: *const c_char,
    /// 1 for two's complement, 0 for unsigned.
    pub is_signed: c_int,
    /// Bits (1..=64).
    pub width: u32,
    /// Fraction bits: a code `c` is the value `c * 2^-frac`.
    pub frac: i32,
    /// Integer bits (sign included for signed formats).
    pub int_bits: i32,
    /// Smallest code.
    pub min_code: i64,
    /// Largest code.
    pub max_code: i64,
    /// The set-up port (`frame`, `tri`) that loads this input, or `""`
    /// when it travels with every item (and for outputs).
    pub group: *const c_char,
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_error(msg: &str) {
    let c = CString::new(msg.replace('\0', "\\0")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = c);
}

/// Run `f`, turning an error or a panic into `fallback` and the message.
fn guard<T>(fallback: T, f: impl FnOnce() -> Result<T, String>) -> T {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(v)) => v,
        Ok(Err(msg)) => {
            set_error(&msg);
            fallback
        }
        Err(p) => {
            let why = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown".into());
            set_error(&format!("internal error in fxshade (please report): {why}"));
            fallback
        }
    }
}

/// A C string argument; `NULL` is `None`.
unsafe fn opt_str<'a>(p: *const c_char, what: &str) -> Result<Option<&'a str>, String> {
    if p.is_null() {
        return Ok(None);
    }
    CStr::from_ptr(p)
        .to_str()
        .map(Some)
        .map_err(|_| format!("{what} is not UTF-8"))
}

fn cstring(s: &str) -> CString {
    CString::new(s.replace('\0', "\\0")).unwrap_or_default()
}

fn wrap(model: UnitModel) -> Box<FxsUnit> {
    let ports = model.inputs().iter().chain(model.outputs());
    let names = ports.clone().map(|f| cstring(&f.name)).collect();
    let formats = ports.map(|f| cstring(&f.format.to_string())).collect();
    let groups = model
        .inputs()
        .iter()
        .map(|f| cstring(model.setup_group(&f.name).unwrap_or("")))
        .chain(model.outputs().iter().map(|_| cstring("")))
        .collect();
    let flags = model.flags().iter().map(|s| cstring(s)).collect();
    Box::new(FxsUnit {
        names,
        formats,
        groups,
        flags,
        module: cstring(model.module()),
        manifest: cstring(&model.manifest().to_string()),
        layout: cstring(&model.layout()),
        model,
    })
}

fn open(
    unit: &str,
    text: Option<&str>,
    path: Option<&str>,
    sets: &[String],
) -> Result<UnitModel, ModelError> {
    let source = match (text, path) {
        (Some(t), _) => ConfigSource::Text {
            text: t,
            name: path.unwrap_or("<configuration text>"),
        },
        (None, Some(p)) => ConfigSource::File(Path::new(p)),
        (None, None) => ConfigSource::Default,
    };
    UnitModel::open(unit, source, sets)
}

/// The version of this ABI (and of the layout strings it checks): 1.
#[no_mangle]
pub extern "C" fn fxs_abi_version() -> u32 {
    ABI_VERSION
}

/// The message of the last failed call on this thread (`""` if none). The
/// pointer stays valid until the next failing call on this thread.
#[no_mangle]
pub extern "C" fn fxs_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// Open `unit` (`normalize`, `polar`, ..., `pipeline`; see `fxshade rtl
/// list`) for a configuration: `config_toml` (TOML text; `config_path`
/// then only names it in messages) or else the file `config_path`, or
/// else (both `NULL`) the embedded default; then the `n_sets` overrides
/// `sets[0..n_sets]` (`KEY=VALUE`, as `--set`; a variant is chosen this
/// way, e.g. `normalize.method="linear"` or `pipeline.path="mapped"`).
/// Returns `NULL` on an error ([`fxs_last_error`]: the command line's
/// message). Close it with [`fxs_close`].
///
/// # Safety
/// `unit` is a NUL-terminated string; `config_toml` and `config_path` are
/// `NULL` or NUL-terminated; `sets` points to `n_sets` NUL-terminated
/// strings (or is `NULL` with `n_sets` 0).
#[no_mangle]
pub unsafe extern "C" fn fxs_open(
    unit: *const c_char,
    config_toml: *const c_char,
    config_path: *const c_char,
    sets: *const *const c_char,
    n_sets: usize,
) -> *mut FxsUnit {
    guard(std::ptr::null_mut(), || {
        let unit = opt_str(unit, "the unit name")?.ok_or("the unit name is NULL")?;
        let text = opt_str(config_toml, "the configuration text")?;
        let path = opt_str(config_path, "the configuration path")?;
        let mut overrides = Vec::with_capacity(n_sets);
        if n_sets > 0 {
            if sets.is_null() {
                return Err(format!("sets is NULL with n_sets = {n_sets}"));
            }
            for k in 0..n_sets {
                let s = opt_str(*sets.add(k), "an override")?
                    .ok_or_else(|| format!("override {k} is NULL"))?;
                overrides.push(s.to_string());
            }
        }
        let m = open(unit, text, path, &overrides).map_err(|e| e.to_string())?;
        Ok(Box::into_raw(wrap(m)))
    })
}

/// Close a unit from [`fxs_open`] (`NULL` is ignored).
///
/// # Safety
/// `u` is `NULL` or a unit from [`fxs_open`] not closed before.
#[no_mangle]
pub unsafe extern "C" fn fxs_close(u: *mut FxsUnit) {
    if !u.is_null() {
        drop(Box::from_raw(u));
    }
}

/// Input ports (every field of a row, set-up fields included).
///
/// # Safety
/// `u` is an open unit.
#[no_mangle]
pub unsafe extern "C" fn fxs_num_inputs(u: *const FxsUnit) -> usize {
    (*u).model.inputs().len()
}

/// Output ports (the flag word apart).
///
/// # Safety
/// `u` is an open unit.
#[no_mangle]
pub unsafe extern "C" fn fxs_num_outputs(u: *const FxsUnit) -> usize {
    (*u).model.outputs().len()
}

/// Overflow-flag stages (bits of the flag word; at most 64).
///
/// # Safety
/// `u` is an open unit.
#[no_mangle]
pub unsafe extern "C" fn fxs_num_flags(u: *const FxsUnit) -> usize {
    (*u).model.flags().len()
}

/// The stage id of flag `k` (bit `F-1-k` of the flag word), or `NULL`
/// when `k` is out of range. Valid until [`fxs_close`].
///
/// # Safety
/// `u` is an open unit.
#[no_mangle]
pub unsafe extern "C" fn fxs_flag_stage(u: *const FxsUnit, k: usize) -> *const c_char {
    let u = &*u;
    u.flags.get(k).map_or(std::ptr::null(), |s| s.as_ptr())
}

/// Cycles from an input transfer to its output in the emitted module
/// (no stalls).
///
/// # Safety
/// `u` is an open unit.
#[no_mangle]
pub unsafe extern "C" fn fxs_latency(u: *const FxsUnit) -> u32 {
    (*u).model.latency()
}

/// The emitted module's name (`normalize`, `pipeline_smooth`, ...).
///
/// # Safety
/// `u` is an open unit.
#[no_mangle]
pub unsafe extern "C" fn fxs_module(u: *const FxsUnit) -> *const c_char {
    (*u).module.as_ptr()
}

/// The unit's manifest as JSON text: the vector manifest's fields (names,
/// formats, bit positions, flag order, latency, set-up ports, parameters)
/// with `layout` and `abi_version`. Valid until [`fxs_close`].
///
/// # Safety
/// `u` is an open unit.
#[no_mangle]
pub unsafe extern "C" fn fxs_manifest(u: *const FxsUnit) -> *const c_char {
    (*u).manifest.as_ptr()
}

/// The one-line port layout (`abi=1;unit=...;module=...;in=...;out=...;flags=F`)
/// that generated callers compare. Valid until [`fxs_close`].
///
/// # Safety
/// `u` is an open unit.
#[no_mangle]
pub unsafe extern "C" fn fxs_layout(u: *const FxsUnit) -> *const c_char {
    (*u).layout.as_ptr()
}

fn port(u: &FxsUnit, k: usize, out: bool, p: &mut FxsPort) -> Result<c_int, String> {
    let m = &u.model;
    let (list, base) = if out {
        (m.outputs(), m.inputs().len())
    } else {
        (m.inputs(), 0)
    };
    let f = list.get(k).ok_or_else(|| {
        format!(
            "{} port {k} does not exist: the unit has {}",
            if out { "output" } else { "input" },
            list.len()
        )
    })?;
    *p = FxsPort {
        name: u.names[base + k].as_ptr(),
        format: u.formats[base + k].as_ptr(),
        is_signed: f.format.signed() as c_int,
        width: f.format.width(),
        frac: f.format.frac(),
        int_bits: f.format.int_bits(),
        min_code: f.format.min_code() as i64,
        max_code: f.format.max_code() as i64,
        group: u.groups[base + k].as_ptr(),
    };
    Ok(0)
}

/// Describe input port `k` into `*port`: 0, or -1 when `k` is out of range.
///
/// # Safety
/// `u` is an open unit; `port` points to writable memory for one
/// [`FxsPort`].
#[no_mangle]
pub unsafe extern "C" fn fxs_input(u: *const FxsUnit, k: usize, port_out: *mut FxsPort) -> c_int {
    guard(-1, || port(&*u, k, false, &mut *port_out))
}

/// Describe output port `k` into `*port`: 0, or -1 when `k` is out of
/// range.
///
/// # Safety
/// As [`fxs_input`].
#[no_mangle]
pub unsafe extern "C" fn fxs_output(u: *const FxsUnit, k: usize, port_out: *mut FxsPort) -> c_int {
    guard(-1, || port(&*u, k, true, &mut *port_out))
}

/// Evaluate `n` rows: `inputs[i*I + j]` is input `j` of row `i` (`I` =
/// [`fxs_num_inputs`]); writes `outputs[i*O + j]` (`O` =
/// [`fxs_num_outputs`]) and, unless `flags` is `NULL`, the flag word
/// `flags[i]`. Returns 0, or -1 when an input code lies outside its
/// port's format ([`fxs_last_error`] names the row, the port and the
/// range; nothing is written).
///
/// # Safety
/// `u` is an open unit; `inputs` holds `n*I` values, `outputs` room for
/// `n*O`, `flags` room for `n` (or is `NULL`).
#[no_mangle]
pub unsafe extern "C" fn fxs_eval(
    u: *const FxsUnit,
    n: usize,
    inputs: *const i64,
    outputs: *mut i64,
    flags: *mut u64,
) -> c_int {
    guard(-1, || {
        let m = &(*u).model;
        let (ni, no) = (m.inputs().len(), m.outputs().len());
        let ins = slice(inputs, n * ni, "inputs")?;
        let outs = slice_mut(outputs, n * no, "outputs")?;
        let fl = if flags.is_null() {
            None
        } else {
            Some(std::slice::from_raw_parts_mut(flags, n))
        };
        m.eval(n, ins, outs, fl).map_err(|e| e.to_string())?;
        Ok(0)
    })
}

unsafe fn slice<'a>(p: *const i64, n: usize, what: &str) -> Result<&'a [i64], String> {
    if n == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err(format!("{what} is NULL"));
    }
    Ok(std::slice::from_raw_parts(p, n))
}

unsafe fn slice_mut<'a>(p: *mut i64, n: usize, what: &str) -> Result<&'a mut [i64], String> {
    if n == 0 {
        return Ok(&mut []);
    }
    if p.is_null() {
        return Err(format!("{what} is NULL"));
    }
    Ok(std::slice::from_raw_parts_mut(p, n))
}

/// DPI-C: open `unit` for the TOML text `config_toml` (the embedded
/// default when empty) with `sets` (overrides separated by `;`), and
/// refuse it unless its layout is `layout` (when not empty). `NULL` on an
/// error ([`fxs_dpi_error`]).
///
/// # Safety
/// Every argument is a NUL-terminated string.
#[no_mangle]
pub unsafe extern "C" fn fxs_dpi_open(
    unit: *const c_char,
    config_toml: *const c_char,
    sets: *const c_char,
    layout: *const c_char,
) -> *mut FxsUnit {
    guard(std::ptr::null_mut(), || {
        let unit = opt_str(unit, "the unit name")?.unwrap_or("");
        let text = opt_str(config_toml, "the configuration text")?.filter(|t| !t.is_empty());
        let sets: Vec<String> = opt_str(sets, "the overrides")?
            .map(|s| {
                fxshade_model::rtl::units::overrides(s)
                    .map(str::to_string)
                    .collect()
            })
            .unwrap_or_default();
        let layout = opt_str(layout, "the layout")?.unwrap_or("");
        let source = if text.is_some() {
            Some("<dpi package configuration>")
        } else {
            None
        };
        let m = open(unit, text, source, &sets).map_err(|e| e.to_string())?;
        m.check_layout(layout).map_err(|e| e.to_string())?;
        if m.inputs().len() > 64 || m.outputs().len() > 64 {
            return Err(format!(
                "{} has more than 64 input or output ports",
                m.module()
            ));
        }
        Ok(Box::into_raw(wrap(m)))
    })
}

/// DPI-C: the last error on this thread.
#[no_mangle]
pub extern "C" fn fxs_dpi_error() -> *const c_char {
    fxs_last_error()
}

/// DPI-C: evaluate one row; `in_codes[0..I]` in, `out_codes[0..O]` and
/// `*flags` out (the rest of the arrays untouched). 0, or -1 on an error.
///
/// # Safety
/// `u` is an open unit; `in_codes` and `out_codes` hold 64 values;
/// `flags` points to one.
#[no_mangle]
pub unsafe extern "C" fn fxs_dpi_eval(
    u: *const FxsUnit,
    in_codes: *const i64,
    out_codes: *mut i64,
    flags: *mut u64,
) -> c_int {
    guard(-1, || {
        if u.is_null() {
            return Err("the model handle is null (fxs_dpi_open failed)".into());
        }
        let m = &(*u).model;
        let (ni, no) = (m.inputs().len(), m.outputs().len());
        let ins = slice(in_codes, ni, "in_codes")?;
        let outs = slice_mut(out_codes, no, "out_codes")?;
        let mut f = [0u64];
        m.eval(1, ins, outs, Some(&mut f))
            .map_err(|e| e.to_string())?;
        if !flags.is_null() {
            *flags = f[0];
        }
        Ok(0)
    })
}

/// DPI-C: close a model (`NULL` is ignored).
///
/// # Safety
/// As [`fxs_close`].
#[no_mangle]
pub unsafe extern "C" fn fxs_dpi_close(u: *mut FxsUnit) {
    fxs_close(u)
}
