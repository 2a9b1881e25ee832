//! The bundled default dataset: 20 minutes of DRIVE driving with a Clearpath Husky, from the
//! public DRIVE repository (BSD-3-Clause, see `data/LICENSE-DATA`).

use drive_data::{parse_dataset, DataError, DataErrorKind, Location};
use drive_traits::Dataset;
use std::io::Read;

/// Name used for the bundled CSV in messages.
pub const HUSKY_CSV_NAME: &str = "bundled:husky_drive.csv";
const HUSKY_CSV_GZ: &[u8] = include_bytes!("../data/husky_drive.csv.gz");
const HUSKY_SIDECAR: &str = include_str!("../data/husky_drive.json");

/// The bundled Husky dataset (603 windows of 2 s at 20 Hz, 201 DRIVE intervals).
///
/// ```
/// let data = drive::bundled::husky().unwrap();
/// assert_eq!(data.windows.len(), 603);
/// assert_eq!(data.interval_count(), 201);
/// assert_eq!(data.robot.vehicle.geometry(), vec![("wheel_radius", 0.165), ("baseline", 0.55)]);
/// ```
pub fn husky() -> Result<Dataset, DataError> {
    let mut text = String::new();
    flate2::read::GzDecoder::new(HUSKY_CSV_GZ)
        .read_to_string(&mut text)
        .map_err(|e| {
            DataError::new(
                Location::file(HUSKY_CSV_NAME),
                DataErrorKind::Io(e.to_string()),
            )
        })?;
    parse_dataset(
        HUSKY_CSV_NAME,
        &text,
        "bundled:husky_drive.json",
        HUSKY_SIDECAR,
    )
}
