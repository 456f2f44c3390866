//! The embedded interpreter: finds usd-core, runs `helper.py`, and copies what it returns into
//! plain Rust values ([`RawStage`]), so nothing past this file touches Python.
//!
//! An embedded CPython ignores `VIRTUAL_ENV`, so the venv's site-packages is added by hand
//! (`site.addsitedir`, which also runs the venv's `.pth` files). Every Python exception becomes
//! a diagnostic carrying its message only: a designer should never see a traceback.

use std::ffi::CString;
use std::path::{Path, PathBuf};

use pyo3::buffer::PyBuffer;
use pyo3::prelude::*;
use pyo3::types::{PyList, PyModule, PyTuple};

use super::stage::{RawMesh, RawPrim, RawStage};
use crate::diag::{Code, Diagnostic, Location};

const HELPER: &str = include_str!("helper.py");

/// The project's own venv (made by scripts/test.sh), the last place looked.
const PROJECT_VENV: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/.venv");

/// Where usd-core is looked for, and why there.
struct Venv {
    dir: PathBuf,
    /// How the venv was chosen, for messages.
    from: &'static str,
}

fn choose_venv(explicit: Option<&Path>) -> Option<Venv> {
    if let Some(dir) = explicit {
        // Absolute, so `sys.path` does not depend on Python's idea of the current folder.
        return Some(Venv {
            dir: std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf()),
            from: "--python-venv",
        });
    }
    if let Some(dir) = std::env::var_os("VIRTUAL_ENV").filter(|v| !v.is_empty()) {
        return Some(Venv {
            dir: PathBuf::from(dir),
            from: "VIRTUAL_ENV",
        });
    }
    let project = PathBuf::from(PROJECT_VENV);
    project.is_dir().then_some(Venv {
        dir: project,
        from: "the project's .venv",
    })
}

/// The venv's site-packages for the embedded interpreter's version; `Err` names the versions
/// the venv was made for when none matches (a cp312 wheel cannot load into libpython3.11).
fn site_packages(venv: &Path, major: u8, minor: u8) -> Result<PathBuf, String> {
    let want = venv.join(format!("lib/python{major}.{minor}/site-packages"));
    if want.is_dir() {
        return Ok(want);
    }
    let windows = venv.join("Lib/site-packages");
    if windows.is_dir() {
        return Ok(windows);
    }
    let found: Vec<String> = std::fs::read_dir(venv.join("lib"))
        .map(|d| {
            d.flatten()
                .filter_map(|e| e.file_name().to_str().map(str::to_string))
                .filter(|n| n.starts_with("python"))
                .collect()
        })
        .unwrap_or_default();
    Err(if found.is_empty() {
        format!("`{}` has no site-packages folder", venv.display())
    } else {
        format!(
            "`{}` is for {}, but portcullis embeds Python {major}.{minor}",
            venv.display(),
            found.join(", ")
        )
    })
}

fn missing(path: &Path, why: String) -> Diagnostic {
    Diagnostic::new(
        Code::USD_CORE_MISSING,
        format!(
            "cannot read `{}`: Pixar's usd-core Python package is not available ({why})",
            path.display()
        ),
        Location::file(path),
    )
    .hint(format!(
        "install it with `{}` at the repository root, or pass `--python-venv DIR` (or set \
         VIRTUAL_ENV) for a venv that has it",
        super::install_command()
    ))
}

/// Adds the chosen venv to `sys.path`; `Err` is a sentence saying what is wrong with it.
fn add_venv(py: Python<'_>, venv: &Option<Venv>) -> Result<(), String> {
    let Some(v) = venv else {
        return Ok(());
    };
    if !v.dir.is_dir() {
        return Err(format!(
            "the venv `{}` given by {} does not exist",
            v.dir.display(),
            v.from
        ));
    }
    let info = py.version_info();
    let sp = site_packages(&v.dir, info.major, info.minor)?;
    let added = (|| -> PyResult<()> {
        let sys_path = py.import("sys")?.getattr("path")?;
        let s = sp.to_string_lossy().into_owned();
        if !sys_path.contains(&s)? {
            py.import("site")?.call_method1("addsitedir", (s,))?;
        }
        Ok(())
    })();
    added.map_err(|e| format!("adding `{}` failed: {e}", sp.display()))
}

/// Reads the composed stage at `path`.
pub(crate) fn read_stage(path: &Path, venv: Option<&Path>) -> Result<RawStage, Diagnostic> {
    let venv = choose_venv(venv);
    Python::attach(|py| {
        add_venv(py, &venv).map_err(|why| missing(path, why))?;
        let helper = load_helper(py).map_err(|e| python_failed(py, path, e))?;
        let result = match helper
            .getattr("load")
            .and_then(|f| f.call1((path.to_string_lossy().into_owned(),)))
        {
            Ok(r) => r,
            Err(e) => return Err(classify(py, path, &venv, e)),
        };
        convert(py, &result).map_err(|e| python_failed(py, path, e))
    })
}

fn load_helper(py: Python<'_>) -> PyResult<Bound<'_, PyModule>> {
    let code = CString::new(HELPER).map_err(|e| {
        pyo3::exceptions::PyValueError::new_err(format!("helper has a NUL byte: {e}"))
    })?;
    PyModule::from_code(
        py,
        &code,
        c"portcullis_usd_helper.py",
        c"portcullis_usd_helper",
    )
}

/// A Python exception from `helper.load` as a diagnostic.
fn classify(py: Python<'_>, path: &Path, venv: &Option<Venv>, e: PyErr) -> Diagnostic {
    let ty = e
        .get_type(py)
        .name()
        .map(|n| n.to_string())
        .unwrap_or_default();
    let msg = e.value(py).to_string();
    if e.is_instance_of::<pyo3::exceptions::PyImportError>(py) {
        let looked = match venv {
            Some(v) => format!("looked in `{}` from {}", v.dir.display(), v.from),
            None => "no venv given, VIRTUAL_ENV unset, and the project has no .venv".to_string(),
        };
        return missing(path, format!("{msg}; {looked}"));
    }
    if ty == "OpenError" {
        return Diagnostic::new(
            Code::USD_OPEN_FAILED,
            format!("USD cannot open `{}`: {msg}", path.display()),
            Location::file(path),
        )
        .hint("fix the file (the message is USD's own), or re-export it from the modelling tool");
    }
    Diagnostic::new(
        Code::USD_PYTHON_FAILED,
        format!(
            "reading `{}` through usd-core failed: {ty}: {msg}",
            path.display()
        ),
        Location::file(path),
    )
    .hint("the stage may use something portcullis does not expect; please report it with the file")
}

fn python_failed(py: Python<'_>, path: &Path, e: PyErr) -> Diagnostic {
    classify(py, path, &None, e)
}

type PrimTuple<'py> = (
    String,
    String,
    i64,
    String,
    PyBuffer<f64>,
    Option<String>,
    Option<String>,
    Bound<'py, PyAny>,
);

type MeshTuple = (
    PyBuffer<f32>,
    PyBuffer<i32>,
    PyBuffer<i32>,
    PyBuffer<i32>,
    bool,
    Option<PyBuffer<i32>>,
);

fn convert(py: Python<'_>, result: &Bound<'_, PyAny>) -> PyResult<RawStage> {
    let t = result.cast::<PyTuple>()?;
    let up: String = t.get_item(0)?.extract()?;
    let meters_per_unit: f64 = t.get_item(1)?.extract()?;
    let list = t.get_item(2)?;
    let list = list.cast::<PyList>()?;
    let materials: Vec<(String, String)> = t.get_item(3)?.extract()?;
    let notes: Vec<(String, String)> = t.get_item(4)?.extract()?;
    let mut prims = Vec::with_capacity(list.len());
    for item in list.iter() {
        let (path, name, parent, _type_name, world, extras, mesh_key, mesh): PrimTuple =
            item.extract()?;
        let m = world.to_vec(py)?;
        let world: [f64; 16] = m.try_into().map_err(|v: Vec<f64>| {
            pyo3::exceptions::PyValueError::new_err(format!(
                "a world matrix has {} numbers, not 16",
                v.len()
            ))
        })?;
        let mesh = if mesh.is_none() {
            None
        } else {
            let (points, counts, indices, holes, left_handed, face_materials): MeshTuple =
                mesh.extract()?;
            Some(RawMesh {
                points: points.to_vec(py)?,
                counts: counts.to_vec(py)?,
                indices: indices.to_vec(py)?,
                holes: holes.to_vec(py)?,
                left_handed,
                face_materials: face_materials.map(|b| b.to_vec(py)).transpose()?,
            })
        };
        prims.push(RawPrim {
            path,
            name,
            parent: usize::try_from(parent).ok(),
            world,
            extras,
            mesh_key,
            mesh,
        });
    }
    Ok(RawStage {
        up,
        meters_per_unit,
        prims,
        materials,
        notes,
    })
}
