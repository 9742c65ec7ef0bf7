//! A planetary set given directly as a lumped-parameter model (masses,
//! rotational masses I/r², support stiffnesses, constant mesh stiffnesses,
//! pressure angles, planet angles), so published benchmark systems can be
//! entered as they are printed.

use serde::{Deserialize, Serialize};

use super::{units, SceneError};
use super::{Fidelity, Member};

/// One central member of a lumped scene.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CentralSpec {
    /// Mass \[kg\].
    pub mass_kg: f64,
    /// Rotational mass I/r² \[kg\] (r: base radius, or centre distance for the carrier).
    pub rotational_mass_kg: f64,
    /// Bearing stiffness per translation direction [N/m].
    pub bearing_n_per_m: f64,
    /// Torsional support stiffness on u = rθ [N/m] (0: free).
    #[serde(default)]
    pub torsional_n_per_m: f64,
}

/// The planets of a lumped scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanetSpec {
    /// Mass \[kg\].
    pub mass_kg: f64,
    /// Rotational mass I/r_b² \[kg\].
    pub rotational_mass_kg: f64,
    /// Planet bearing stiffness, radial and tangential [N/m].
    pub bearing_n_per_m: f64,
    /// Number of planets (equally spaced unless `angles` is given).
    pub count: u32,
    /// Planet angles \[rad\] (file: `angles_deg`).
    #[serde(rename = "angles_deg", with = "units::deg", default, skip_serializing_if = "Option::is_none")]
    pub angles: Option<Vec<f64>>,
}

/// The model section of a lumped scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LumpedSpec {
    /// Degrees of freedom.
    pub fidelity: Fidelity,
    /// Member held in rotation, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held: Option<Member>,
    /// Carrier.
    pub carrier: CentralSpec,
    /// Ring.
    pub ring: CentralSpec,
    /// Sun.
    pub sun: CentralSpec,
    /// Planets.
    pub planet: PlanetSpec,
    /// Sun–planet mesh stiffness [N/m].
    pub sun_mesh_n_per_m: f64,
    /// Ring–planet mesh stiffness [N/m].
    pub ring_mesh_n_per_m: f64,
    /// Sun–planet pressure angle \[rad\] (file: `sun_pressure_angle_deg`).
    #[serde(rename = "sun_pressure_angle_deg", with = "units::deg")]
    pub sun_pressure_angle: f64,
    /// Ring–planet pressure angle \[rad\] (file: `ring_pressure_angle_deg`).
    #[serde(rename = "ring_pressure_angle_deg", with = "units::deg")]
    pub ring_pressure_angle: f64,
}

/// A lumped scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LumpedScene {
    /// Name.
    pub name: String,
    /// The model.
    pub lumped: LumpedSpec,
}

impl LumpedScene {
    /// Parses a lumped scene from TOML.
    pub fn from_toml(text: &str) -> Result<Self, SceneError> {
        toml::from_str(text).map_err(|e| SceneError::Syntax { message: e.to_string() })
    }

    /// A benchmark-style system with the orders of magnitude of the example
    /// in Lin & Parker (1999) — the values are this project's, not a copy of
    /// the paper's table: four planets, nothing held, ring torsional support
    /// 1e9 N/m, bearings 1e8 N/m, meshes 5e8 N/m, 24.6° pressure angles.
    pub fn lumped_benchmark() -> Self {
        let c = |m: f64, j: f64, t: f64| CentralSpec {
            mass_kg: m,
            rotational_mass_kg: j,
            bearing_n_per_m: 1e8,
            torsional_n_per_m: t,
        };
        Self {
            name: "lumped-benchmark".into(),
            lumped: LumpedSpec {
                fidelity: Fidelity::TransverseTorsional,
                held: None,
                carrier: c(5.43, 6.29, 0.0),
                ring: c(2.35, 3.00, 1e9),
                sun: c(0.40, 0.39, 0.0),
                planet: PlanetSpec {
                    mass_kg: 0.66,
                    rotational_mass_kg: 0.61,
                    bearing_n_per_m: 1e8,
                    count: 4,
                    angles: None,
                },
                sun_mesh_n_per_m: 5e8,
                ring_mesh_n_per_m: 5e8,
                sun_pressure_angle: units::deg_to_rad(24.6),
                ring_pressure_angle: units::deg_to_rad(24.6),
            },
        }
    }

    /// The scene as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_default()
    }
}
