//! The bundled datasets (see [`drive_data::bundled`]): real DRIVE runs of a Clearpath Husky
//! and of a Clearpath Warthog on several terrains, from the public norlab repositories
//! (BSD-3-Clause, see `data/LICENSE-DATA`), loadable wherever a dataset path is accepted as
//! `bundled:NAME`.

use drive_data::DataError;
use drive_traits::Dataset;

pub use drive_data::bundled::{find, load, names, Bundled, BUNDLED, PREFIX};

/// Name used for the bundled Husky CSV in messages.
pub const HUSKY_CSV_NAME: &str = "bundled:husky_drive.csv";

/// The bundled Husky dataset (603 windows of 2 s at 20 Hz, 201 DRIVE intervals), the default
/// dataset of every command.
///
/// ```
/// let data = drive::bundled::husky().unwrap();
/// assert_eq!(data.windows.len(), 603);
/// assert_eq!(data.interval_count(), 201);
/// assert_eq!(data.robot.vehicle.geometry(), vec![("wheel_radius", 0.165), ("baseline", 0.55)]);
/// ```
pub fn husky() -> Result<Dataset, DataError> {
    load("husky_drive")
}
