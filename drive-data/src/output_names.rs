//! What a file written by this project may be named: an output is never written under a
//! name that says another kind of file (a model file as `run.csv` or `model.npy`, a CSV as
//! `run.json`), nor over a dataset's sidecar (`run.meta.json`, or `run.json` beside
//! `run.csv`, the name of earlier releases), nor, for a file that is not a dataset, over a
//! dataset's CSV (its sidecar left beside something else). The command line's outputs and
//! Python's `save` follow the same rules.

use std::path::{Path, PathBuf};

/// The endings of datasets, their sidecars and recordings, and of the array and table files
/// a researcher keeps data in: never the name of a model file, a twin or a schedule.
pub const DATA_NAMES: &[&str] = &[
    ".csv",
    ".csv.gz",
    ".meta.json",
    ".mcap",
    ".db3",
    ".bag",
    ".npy",
    ".npz",
    ".parquet",
    ".pkl",
    ".pickle",
    ".h5",
    ".hdf5",
    ".mat",
    ".feather",
];

/// The endings a CSV is never written under: other kinds of files (JSON, TOML, YAML, pages,
/// figures, recordings, arrays) and a compressed one (a CSV is written as text).
pub const NOT_CSV_NAMES: &[&str] = &[
    ".gz", ".json", ".toml", ".yaml", ".yml", ".md", ".html", ".svg", ".png", ".mcap", ".db3",
    ".bag", ".npy", ".npz", ".parquet", ".pkl", ".pickle", ".h5", ".hdf5", ".mat", ".feather",
];

/// Why a name is refused for an output ([`refused_name`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NameError {
    /// The name ends in an ending of another kind of file.
    #[error("{path}: {kind} is written there, and the name says {ending}: name it for what it is")]
    OtherKind {
        /// The path.
        path: String,
        /// What would be written (`a model file (JSON)`).
        kind: String,
        /// The ending its name has.
        ending: String,
    },
    /// The path is a dataset's sidecar.
    #[error("{path}: the sidecar of the dataset {csv} (written with it, read with it): {kind} written there would replace it, and the dataset would no longer load; name it otherwise")]
    Sidecar {
        /// The path.
        path: String,
        /// The dataset's CSV beside it.
        csv: String,
        /// What would be written.
        kind: String,
    },
    /// The path is a dataset's CSV, and what is written is not a dataset.
    #[error("{path}: a dataset's CSV (its sidecar {sidecar} beside it): {kind} written there would replace it and leave its sidecar describing something else; name it otherwise")]
    DatasetCsv {
        /// The path.
        path: String,
        /// The sidecar beside it.
        sidecar: String,
        /// What would be written.
        kind: String,
    },
}

/// `Err` where `path` may not hold `kind` (`a model file (JSON)`): its name ends (case
/// aside) in one of `refused`, or it is a dataset's sidecar (`X.meta.json`, or `X.json`
/// where `X.csv` or `X.csv.gz` exists beside it and `X.meta.json` does not), or, unless `dataset` (what is written is a
/// dataset, with its own sidecar), an existing dataset's CSV (`X.csv` with `X.meta.json` or
/// `X.json` beside it).
///
/// ```
/// use drive_data::output_names::{refused_name, DATA_NAMES};
/// use std::path::Path;
/// let dir = std::env::temp_dir().join(format!("drive-names-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// std::fs::write(dir.join("run.csv"), "t\n").unwrap();
/// std::fs::write(dir.join("run.json"), "{}").unwrap();
/// let model = "a model file (JSON)";
/// assert!(refused_name(&dir.join("model.json"), model, DATA_NAMES, false).is_ok());
/// assert!(refused_name(&dir.join("model.npy"), model, DATA_NAMES, false).is_err());
/// // The sidecar of run.csv, by the name of earlier releases.
/// let e = refused_name(&dir.join("run.json"), model, DATA_NAMES, false).unwrap_err();
/// assert!(e.to_string().contains("the sidecar of the dataset"), "{e}");
/// // A per-window CSV over the dataset run.csv; a dataset may replace it.
/// let per_window = "a per-window CSV";
/// assert!(refused_name(&dir.join("run.csv"), per_window, &[".json"], false).is_err());
/// assert!(refused_name(&dir.join("run.csv"), "a dataset", &[".json"], true).is_ok());
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn refused_name(
    path: &Path,
    kind: &str,
    refused: &[&str],
    dataset: bool,
) -> Result<(), NameError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let shown = path.display().to_string();
    if let Some(ending) = refused
        .iter()
        .find(|e| name.ends_with(&e.to_ascii_lowercase()))
    {
        return Err(NameError::OtherKind {
            path: shown,
            kind: kind.to_string(),
            ending: ending.to_string(),
        });
    }
    if let Some(csv) = dataset_of_sidecar(path) {
        return Err(NameError::Sidecar {
            path: shown,
            csv: csv.display().to_string(),
            kind: kind.to_string(),
        });
    }
    if !dataset {
        if let Some(sidecar) = sidecar_beside(path) {
            return Err(NameError::DatasetCsv {
                path: shown,
                sidecar: sidecar.display().to_string(),
                kind: kind.to_string(),
            });
        }
    }
    Ok(())
}

/// The dataset CSV whose sidecar `path` is: a `X.csv` or `X.csv.gz` beside it that exists
/// and reads `path` as its sidecar ([`crate::sidecar_to_read`]: `X.meta.json`, or the
/// earlier releases' `X.json` where that one is not there).
fn dataset_of_sidecar(path: &Path) -> Option<PathBuf> {
    let name = path.file_name()?.to_string_lossy().to_string();
    let lower = name.to_ascii_lowercase();
    let ending = [".meta.json", ".json"]
        .into_iter()
        .find(|e| lower.ends_with(e))?;
    let stem = &name[..name.len() - ending.len()];
    [".csv", ".csv.gz", ".CSV", ".gz"]
        .iter()
        .map(|e| path.with_file_name(format!("{stem}{e}")))
        .find(|csv| csv.is_file() && crate::sidecar_to_read(csv) == path)
}

/// The sidecar beside `path` where `path` is an existing dataset CSV (`X.csv` or `X.csv.gz`
/// whose sidecar, [`crate::sidecar_to_read`], exists).
fn sidecar_beside(path: &Path) -> Option<PathBuf> {
    let lower = path.file_name()?.to_string_lossy().to_ascii_lowercase();
    if !(path.is_file() && (lower.ends_with(".csv") || lower.ends_with(".csv.gz"))) {
        return None;
    }
    let sidecar = crate::sidecar_to_read(path);
    sidecar.is_file().then_some(sidecar)
}
