//! The datasets bundled with the project: real DRIVE runs from the public norlab
//! repositories (BSD-3-Clause, see `data/LICENSE-DATA`), compressed into the library and
//! loadable by name wherever a dataset path is accepted: `bundled:NAME`
//! ([`read_dataset`](crate::read_dataset) resolves it).
//!
//! | name | robot | terrain | windows |
//! |---|---|---|---|
//! | `husky_drive` (also `husky`) | Clearpath Husky | not recorded | 603 |
//! | `warthog_drive` | Clearpath Warthog (wheels) | the DRIVE paper's (gravel or ice) | 360 |
//! | `warthog_asphalt_a` | Clearpath Warthog (wheels) | asphalt | 300 |
//! | `warthog_asphalt_2024-08-07` | Clearpath Warthog (wheels) | asphalt | 300 |
//! | `warthog_asphalt_2024-09-20a` | Clearpath Warthog (wheels) | asphalt | 300 |
//! | `warthog_asphalt_2024-09-20b` | Clearpath Warthog (wheels) | asphalt | 300 |
//! | `warthog_asphalt_slow_2024-08-08` | Clearpath Warthog (wheels) | asphalt, slow commands | 300 |
//! | `warthog_grass_2024-08-08` | Clearpath Warthog (wheels) | grass | 90 |
//!
//! ```
//! let data = drive_data::bundled::load("warthog_asphalt_a").unwrap();
//! assert_eq!(data.windows.len(), 300);
//! assert_eq!(data.robot.terrain, "asphalt");
//! // The same through the path form.
//! let same = drive_data::read_dataset(std::path::Path::new("bundled:warthog_asphalt_a"), None).unwrap();
//! assert_eq!(same, data);
//! ```

use crate::{parse_dataset, DataError, DataErrorKind, Location};
use drive_traits::Dataset;
use std::io::Read;

/// The prefix that names a bundled dataset where a path is expected.
pub const PREFIX: &str = "bundled:";

/// One bundled dataset.
#[derive(Debug, Clone, Copy)]
pub struct Bundled {
    /// Its name (`bundled:NAME`).
    pub name: &'static str,
    /// The registered robot preset it was recorded with (its body for the terrain's
    /// unpredictability; see `drive list`).
    pub robot: &'static str,
    /// Windows it holds.
    pub windows: usize,
    /// Its sidecar's `terrain` (free text; empty when not recorded).
    pub terrain: &'static str,
    /// One line: robot, terrain, where it comes from.
    pub description: &'static str,
    csv_gz: &'static [u8],
    sidecar: &'static str,
}

macro_rules! bundled {
    ($name:literal, $robot:literal, $windows:literal, $terrain:literal, $description:literal) => {
        Bundled {
            name: $name,
            robot: $robot,
            windows: $windows,
            terrain: $terrain,
            description: $description,
            csv_gz: include_bytes!(concat!("../../data/", $name, ".csv.gz")),
            sidecar: include_str!(concat!("../../data/", $name, ".meta.json")),
        }
    };
}

/// Every bundled dataset, the default (the Husky) first.
pub const BUNDLED: &[Bundled] = &[
    bundled!(
        "husky_drive",
        "husky",
        603,
        "",
        "Clearpath Husky, 20 min of DRIVE (norlab-ulaval/DRIVE, test_husky)"
    ),
    bundled!(
        "warthog_drive",
        "warthog",
        360,
        "unknown: the DRIVE paper drove its Warthog on gravel and on ice",
        "Clearpath Warthog on wheels, the DRIVE paper's run (norlab-ulaval/DRIVE, test_warthog)"
    ),
    bundled!(
        "warthog_asphalt_a",
        "warthog",
        300,
        "asphalt",
        "Clearpath Warthog on wheels (norlab-ulaval/doughnut_calib)"
    ),
    bundled!(
        "warthog_asphalt_2024-08-07",
        "warthog",
        300,
        "asphalt",
        "Clearpath Warthog on wheels, 2024-08-07 (norlab-ulaval/doughnut_calib)"
    ),
    bundled!(
        "warthog_asphalt_2024-09-20a",
        "warthog",
        300,
        "asphalt",
        "Clearpath Warthog on wheels, 2024-09-20 (norlab-ulaval/doughnut_calib)"
    ),
    bundled!(
        "warthog_asphalt_2024-09-20b",
        "warthog",
        300,
        "asphalt",
        "Clearpath Warthog on wheels, 2024-09-20, second run (norlab-ulaval/doughnut_calib)"
    ),
    bundled!(
        "warthog_asphalt_slow_2024-08-08",
        "warthog",
        300,
        "asphalt",
        "Clearpath Warthog on wheels, commands within about 3 rad/s (norlab-ulaval/doughnut_calib)"
    ),
    bundled!(
        "warthog_grass_2024-08-08",
        "warthog",
        90,
        "grass",
        "Clearpath Warthog on wheels, 2024-08-08 (norlab-ulaval/doughnut_calib)"
    ),
];

/// The bundled dataset of `name` (`husky_drive` or its short form `husky`; a trailing
/// `.csv` is accepted), if there is one.
///
/// ```
/// assert_eq!(drive_data::bundled::find("husky").unwrap().name, "husky_drive");
/// assert_eq!(drive_data::bundled::find("warthog_drive.csv").unwrap().robot, "warthog");
/// assert!(drive_data::bundled::find("mars").is_none());
/// ```
pub fn find(name: &str) -> Option<&'static Bundled> {
    let name = name.trim();
    let name = name.strip_suffix(".csv").unwrap_or(name);
    let name = if name == "husky" { "husky_drive" } else { name };
    BUNDLED.iter().find(|b| b.name == name)
}

/// The name after [`PREFIX`] when `path` names a bundled dataset (`bundled:NAME`).
///
/// ```
/// use std::path::Path;
/// assert_eq!(drive_data::bundled::name_in(Path::new("bundled:husky")), Some("husky"));
/// assert_eq!(drive_data::bundled::name_in(Path::new("runs/husky.csv")), None);
/// ```
pub fn name_in(path: &std::path::Path) -> Option<&str> {
    path.to_str().and_then(|p| p.strip_prefix(PREFIX))
}

/// Loads the bundled dataset of `name` (see [`find`]); an error listing the bundled names
/// when there is none.
pub fn load(name: &str) -> Result<Dataset, DataError> {
    match find(name) {
        Some(b) => b.load(),
        None => Err(DataError::new(
            Location::file(&format!("{PREFIX}{name}")),
            DataErrorKind::NotBundled(format!(
                "no bundled dataset of that name (the bundled datasets are: {})",
                names().join(", ")
            )),
        )),
    }
}

/// The bundled datasets' names.
pub fn names() -> Vec<&'static str> {
    BUNDLED.iter().map(|b| b.name).collect()
}

impl Bundled {
    /// The name of its window CSV in messages (`bundled:NAME.csv`).
    pub fn csv_name(&self) -> String {
        format!("{PREFIX}{}.csv", self.name)
    }

    /// Decompresses and parses the dataset.
    pub fn load(&self) -> Result<Dataset, DataError> {
        let csv_name = self.csv_name();
        let mut text = String::new();
        flate2::read::GzDecoder::new(self.csv_gz)
            .read_to_string(&mut text)
            .map_err(|e| {
                DataError::new(Location::file(&csv_name), DataErrorKind::Io(e.to_string()))
            })?;
        parse_dataset(
            &csv_name,
            &text,
            &format!("{PREFIX}{}.meta.json", self.name),
            self.sidecar,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bundled_dataset_loads_with_its_announced_windows_and_terrain() {
        for b in BUNDLED {
            let data = b.load().unwrap_or_else(|e| panic!("{}: {e}", b.name));
            assert_eq!(data.windows.len(), b.windows, "{}", b.name);
            assert_eq!(data.interval_count() * 3, b.windows, "{}", b.name);
            assert_eq!(data.robot.rate_hz, 20.0);
            assert_eq!(data.robot.terrain, b.terrain, "{}", b.name);
            let label = if b.name.contains("asphalt") {
                "asphalt"
            } else if b.name.contains("grass") {
                "grass"
            } else {
                ""
            };
            assert!(b.terrain.starts_with(label), "{}", b.name);
        }
    }

    #[test]
    fn an_unknown_name_lists_the_bundled_ones() {
        let err = load("mars").unwrap_err().to_string();
        assert!(err.starts_with("bundled:mars"), "{err}");
        assert!(err.contains("warthog_grass_2024-08-08"), "{err}");
    }
}
