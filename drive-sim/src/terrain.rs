//! Terrain presets: the parameters of the traction, skid and rolling-resistance models.
//!
//! Values are typical figures from the terramechanics literature (Wong, *Theory of Ground
//! Vehicles*, 4th ed., 2008, tables of traction and rolling-resistance coefficients;
//! Janosi and Hanamoto 1961 for the shear-deformation modulus), chosen once, per terrain,
//! not tuned to make any protocol or model win.

use drive_traits::{Registry, RegistryItem};
use std::sync::Arc;

/// The ground's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Terrain {
    /// Name.
    pub name: String,
    /// Peak longitudinal traction coefficient mu (traction / normal load).
    pub traction: f64,
    /// Slip at which 63% of the peak traction is reached (shear-deformation modulus over
    /// contact length, as a slip ratio): small on firm ground, large on loose or soft ground.
    pub slip_modulus: f64,
    /// Lateral skid-resistance coefficient mu_t.
    pub lateral: f64,
    /// Rolling-resistance coefficient.
    pub rolling: f64,
}

impl Terrain {
    /// `tile`, `gravel`, `snow` or `ice`.
    ///
    /// ```
    /// let ice = drive_sim::Terrain::preset("ice").unwrap();
    /// assert!(ice.traction < drive_sim::Terrain::preset("tile").unwrap().traction / 5.0);
    /// ```
    pub fn preset(name: &str) -> Option<Terrain> {
        Some(match name {
            // Dry indoor tile / concrete: firm, high friction, low rolling resistance.
            "tile" => Terrain {
                name: "tile".into(),
                traction: 0.8,
                slip_modulus: 0.04,
                lateral: 0.6,
                rolling: 0.015,
            },
            // Loose gravel: medium friction, soft shear response, higher rolling resistance.
            "gravel" => Terrain {
                name: "gravel".into(),
                traction: 0.55,
                slip_modulus: 0.12,
                lateral: 0.5,
                rolling: 0.05,
            },
            // Packed snow: low friction, soft, high rolling resistance (compaction).
            "snow" => Terrain {
                name: "snow".into(),
                traction: 0.3,
                slip_modulus: 0.2,
                lateral: 0.25,
                rolling: 0.08,
            },
            // Resurfaced ice rink: extreme slip.
            "ice" => Terrain {
                name: "ice".into(),
                traction: 0.08,
                slip_modulus: 0.06,
                lateral: 0.05,
                rolling: 0.01,
            },
            _ => return None,
        })
    }

    /// The preset names.
    pub const NAMES: [&'static str; 4] = ["tile", "gravel", "snow", "ice"];
}

impl RegistryItem for Terrain {}

/// The terrain presets by name: `tile`, `gravel`, `snow`, `ice` (see [`Terrain::preset`]).
///
/// ```
/// let terrains = drive_sim::builtin_terrains();
/// assert_eq!(terrains.names(), ["tile", "gravel", "snow", "ice"]);
/// ```
pub fn builtin_terrains() -> Registry<Terrain> {
    let mut r: Registry<Terrain> = Registry::new("terrain");
    for (name, description) in [
        ("tile", "dry indoor tile or concrete: firm, high friction"),
        (
            "gravel",
            "loose gravel: medium friction, soft shear response",
        ),
        (
            "snow",
            "packed snow: low friction, soft, high rolling resistance",
        ),
        ("ice", "resurfaced ice rink: extreme slip"),
    ] {
        // The four presets exist under distinct names.
        let t = Terrain::preset(name).expect("a preset");
        r.register_trusted(name, description, Arc::new(t))
            .expect("distinct presets");
    }
    r
}
