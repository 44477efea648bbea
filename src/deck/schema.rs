//! The TOML deck, mapped 1:1 onto types. Unknown keys are errors everywhere.
//! The reference for users is `docs/deck.md`; every key is in SI units.

use crate::bonds::{PartialVolume, Precrack};
use crate::geometry::Shape;
use crate::loading::{Kinematic, TimeFunction};
use crate::material::pmb::HorizonCoupling;
use crate::material::surface_correction::SurfaceCorrection;
use crate::material::{Influence, MicromodulusProfile};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The newest deck version this peridyn reads.
pub const LATEST_VERSION: u32 = 2;

/// A whole deck.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Deck {
    /// Deck format version: 1 or 2 (`LATEST_VERSION`). Version 2 calibrates the LPS critical
    /// stretch to G0 exactly; version 1 keeps the bond-based equivalent it always had.
    pub version: u32,
    #[serde(default)]
    pub title: String,
    /// 2 or 3.
    pub dimension: usize,
    /// 2D only: "stress" or "strain".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plane: Option<Plane>,
    /// 2D only: out-of-plane thickness (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thickness: Option<f64>,
    pub discretization: Discretization,
    /// The material of every node that no block gives another one.
    pub material: MaterialDeck,
    /// Further materials, by name, for `[[blocks]]` to use.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub materials: BTreeMap<String, MaterialDeck>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub blocks: Vec<BlockDeck>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub node_sets: Vec<NodeSetDeck>,
    /// Fictitious boundary layers outside faces of the body (seed 001 §2.9); each is a node
    /// set of its name.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub boundary_layers: Vec<BoundaryLayerDeck>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub precracks: Vec<Precrack>,
    /// Names of node sets whose bonds never break.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub no_fail: Vec<String>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub boundary_conditions: Vec<BoundaryDeck>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub loads: Vec<LoadDeck>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub initial_velocities: Vec<InitialVelocityDeck>,
    /// Node–node contact (`deck::contact`); absent: off, at no cost.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact: Option<super::contact_schema::ContactDeck>,
    /// Rigid impactors (`deck::contact`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub impactors: Vec<super::contact_schema::ImpactorDeck>,
    pub solver: SolverDeck,
    /// Further stages, run one after the other from where the deck's own stage (the keys
    /// above) left the body: e.g. a quasi-static preload, then explicit dynamics (seed 000
    /// "S + D", seed 002 protocol ii). Empty: a run of one stage.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stages: Vec<StageDeck>,
    #[serde(default)]
    pub output: OutputDeck,
    /// Fracture analysis during the run (crack tip and speed); absent: none, at no cost.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub analysis: Option<AnalysisDeck>,
    /// The `[derived]` table peridyn writes into `resolved.toml`; ignored when read, so a
    /// resolved deck runs again as it is.
    #[serde(default, skip_serializing)]
    pub derived: Option<toml::Table>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Plane {
    Stress,
    Strain,
}

/// Where the nodes come from.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Discretization {
    /// Uniform square/cubic lattice over a shape, nodes at cell centres.
    Lattice {
        shape: Shape,
        /// Lattice spacing Δx (m).
        spacing: f64,
        /// Horizon δ (m); give this or `horizon_ratio`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        horizon: Option<f64>,
        /// δ/Δx; give this or `horizon`. With `refine`, each node's horizon is this times its
        /// own cell size (seed 003: δ_i = m Δx_i, dual-horizon PD).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        horizon_ratio: Option<f64>,
        #[serde(default)]
        partial_volume: PartialVolume,
        /// Surface correction of PMB (seed 000 §2.5); none by default.
        #[serde(default)]
        surface_correction: SurfaceCorrection,
        /// Multi-grid refinement regions (seed 003 §3.1).
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        refine: Vec<RefineDeck>,
        /// Random pores cut from the shape (seed 000 §6).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pores: Option<PoresDeck>,
    },
    /// Boundary-fitted free mesh of a 2D shape (seed 000's global non-uniform grid): nodes at
    /// element centroids, element areas as volumes.
    FreeMesh {
        shape: Shape,
        /// Target element size (m): the boundary is seeded at it.
        size: f64,
        /// Horizon δ (m); give this or `horizon_ratio`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        horizon: Option<f64>,
        /// δ / size; give this or `horizon`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        horizon_ratio: Option<f64>,
        #[serde(default)]
        partial_volume: PartialVolume,
        /// Surface correction of PMB (seed 000 §2.5); none by default.
        #[serde(default)]
        surface_correction: SurfaceCorrection,
        #[serde(default)]
        cells: CellKind,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pores: Option<PoresDeck>,
    },
    /// Near-boundary non-uniform grid (seed 000 §3): a rectangle with circular holes; uniform
    /// cells of `size` except in square boxes around the holes, which get a free mesh.
    Nbnug {
        /// A rectangle, or a difference of a rectangle and disks.
        shape: Shape,
        /// Element size Δx (m).
        size: f64,
        /// Hole-to-box distance (m); default: the horizon δ (seed 000's recommended minimum).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        padding: Option<f64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        horizon: Option<f64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        horizon_ratio: Option<f64>,
        #[serde(default)]
        partial_volume: PartialVolume,
        /// Surface correction of PMB (seed 000 §2.5); none by default.
        #[serde(default)]
        surface_correction: SurfaceCorrection,
        #[serde(default)]
        cells: CellKind,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pores: Option<PoresDeck>,
    },
    /// Nodes read from a text file: `x y [z] volume [block]` (2D: area instead of volume).
    PointCloud {
        /// Path, relative to the deck's folder.
        file: String,
        /// Horizon δ (m).
        horizon: f64,
        #[serde(default)]
        partial_volume: PartialVolume,
        /// Surface correction of PMB (seed 000 §2.5); none by default.
        #[serde(default)]
        surface_correction: SurfaceCorrection,
    },
    /// A Gmsh mesh (`.msh` 4.1 ASCII/binary or 2.2 ASCII): one node per element of the
    /// body's dimension; physical groups give blocks and node sets.
    Gmsh {
        /// Path, relative to the deck's folder.
        file: String,
        /// Horizon δ (m).
        horizon: f64,
        #[serde(default)]
        partial_volume: PartialVolume,
        /// Surface correction of PMB (seed 000 §2.5); none by default.
        #[serde(default)]
        surface_correction: SurfaceCorrection,
    },
}

impl Discretization {
    /// The surface correction the deck asks for.
    pub fn surface_correction(&self) -> SurfaceCorrection {
        match self {
            Discretization::Lattice {
                surface_correction, ..
            }
            | Discretization::FreeMesh {
                surface_correction, ..
            }
            | Discretization::Nbnug {
                surface_correction, ..
            }
            | Discretization::PointCloud {
                surface_correction, ..
            }
            | Discretization::Gmsh {
                surface_correction, ..
            } => *surface_correction,
        }
    }
}

/// A multi-grid refinement region.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RefineDeck {
    pub region: Shape,
    /// Cells inside split this many times (1: Δx/2, 2: Δx/4, ...).
    pub levels: u32,
}

/// Random pores (seed 000 §6), placed in the shape's bounding box.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoresDeck {
    pub count: usize,
    /// [r_min, r_max] (m); radii are uniform in it.
    pub radius: [f64; 2],
    /// Smallest gap between two pores (m).
    #[serde(default)]
    pub clearance: f64,
    pub seed: u64,
}

/// The cells of a free mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum CellKind {
    /// Triangle pairs merged into quadrilaterals where they form good ones (seed 000's mesher).
    #[default]
    QuadDominant,
    Triangles,
}

/// A material: its constitutive model, elastic and fracture properties, and damage law.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum MaterialDeck {
    /// Bond-based prototype microelastic brittle material.
    Pmb {
        /// Mass density ρ (kg/m³).
        density: f64,
        /// Young's modulus E (Pa); or give `micromodulus`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        youngs_modulus: Option<f64>,
        /// c0 (N/m⁶ in 3D; per unit thickness, N/m⁵, in 2D); or give `youngs_modulus`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        micromodulus: Option<f64>,
        /// Only to confirm the bond-based value (1/3 plane stress, 1/4 otherwise).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        poisson_ratio: Option<f64>,
        /// G0 (J/m²), from which the damage law is calibrated.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        fracture_energy: Option<f64>,
        /// s0 given directly (critical-stretch law); or give `fracture_energy`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        critical_stretch: Option<f64>,
        #[serde(default)]
        profile: MicromodulusProfile,
        /// How bonds between nodes of different horizons act: dual-horizon PD (default) or
        /// traditional PD (seed 003 §2.2; non-reciprocal, for comparison).
        #[serde(default, skip_serializing_if = "is_dual")]
        variable_horizon: HorizonCoupling,
        /// The damage law; default: critical stretch.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        damage: Option<DamageDeck>,
        /// IH-PD porosity (seed 001 §4.2).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        porosity: Option<PorosityDeck>,
    },
    /// Linear peridynamic solid (ordinary state-based).
    Lps {
        density: f64,
        youngs_modulus: f64,
        poisson_ratio: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        fracture_energy: Option<f64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        critical_stretch: Option<f64>,
        #[serde(default)]
        influence: Influence,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        damage: Option<DamageDeck>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        porosity: Option<PorosityDeck>,
    },
    /// Non-ordinary state-based correspondence model with zero-energy-mode control.
    Correspondence {
        density: f64,
        youngs_modulus: f64,
        poisson_ratio: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        fracture_energy: Option<f64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        critical_stretch: Option<f64>,
        #[serde(default)]
        influence: Influence,
        #[serde(default)]
        zero_energy_control: ZeroEnergyDeck,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        damage: Option<DamageDeck>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        porosity: Option<PorosityDeck>,
    },
}

/// When bonds break (or soften).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum DamageDeck {
    /// A bond breaks once its stretch exceeds s0 (the material's `critical_stretch`, or
    /// calibrated from its `fracture_energy`).
    CriticalStretch {},
    /// A bond breaks once the work done on it reaches w_c (calibrated from the material's
    /// `fracture_energy`, or given here in J/m⁶).
    CriticalEnergy {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        critical_energy: Option<f64>,
        /// Only bonds in tension fail (seed 004).
        #[serde(default)]
        tension_only: bool,
    },
    /// Bilinear softening bonds (seed 001 §4.1).
    Bilinear {
        /// σu (Pa), for the peak stretch s1 (Eq. 15); or give `peak_stretch`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        tensile_strength: Option<f64>,
        /// s1 given directly.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        peak_stretch: Option<f64>,
        /// sc given directly; otherwise s1·sc = s0² from the material's fracture energy.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        breaking_stretch: Option<f64>,
    },
    /// Trilinear softening bonds (seed 001 §4.3): the bilinear law's s1 and sc, then Eq. 20.
    Trilinear {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        tensile_strength: Option<f64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        peak_stretch: Option<f64>,
        /// The bilinear breaking stretch sc (ŝc follows from Eq. 20).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        breaking_stretch: Option<f64>,
        /// Force at the kink over the peak force (default 1/4).
        #[serde(default = "default_beta")]
        beta: f64,
        /// (ŝc − s1)/(s2 − s1) (default 28/3).
        #[serde(default = "default_gamma")]
        gamma: f64,
    },
    /// Bonds never break.
    None {},
}

fn default_beta() -> f64 {
    crate::damage::softening::SofteningParameters::GENERIC_BETA
}
fn default_gamma() -> f64 {
    crate::damage::softening::SofteningParameters::GENERIC_GAMMA
}

/// IH-PD porosity: solid-phase properties and randomly pre-broken bonds (seed 001 §4.2).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PorosityDeck {
    /// Porosity φ, also the fraction of bonds broken before loading.
    pub porosity: f64,
    /// Critical porosity φc of Eq. 18 (default 1).
    #[serde(default = "default_critical_porosity")]
    pub critical_porosity: f64,
    /// Seed of the pre-broken bonds.
    pub seed: u64,
}

fn default_critical_porosity() -> f64 {
    1.0
}

/// Zero-energy-mode control of the correspondence model.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum ZeroEnergyDeck {
    /// Wan et al. 2019 (seed 004, Eqs. 12–15).
    Wan {
        #[serde(default = "default_one")]
        coefficient: f64,
    },
    /// Silling 2017: T^S = G (c/δ) ω z, an energy-consistent penalty on the non-uniform
    /// deformation (see `material::correspondence`).
    Silling {
        #[serde(default = "default_one")]
        coefficient: f64,
    },
    /// No control.
    None {},
}

fn default_one() -> f64 {
    1.0
}

impl Default for ZeroEnergyDeck {
    fn default() -> Self {
        ZeroEnergyDeck::Wan { coefficient: 1.0 }
    }
}

impl MaterialDeck {
    /// The model's name as decks write it.
    pub fn kind(&self) -> &'static str {
        match self {
            MaterialDeck::Pmb { .. } => "pmb",
            MaterialDeck::Lps { .. } => "lps",
            MaterialDeck::Correspondence { .. } => "correspondence",
        }
    }
    pub fn density(&self) -> f64 {
        match self {
            MaterialDeck::Pmb { density, .. }
            | MaterialDeck::Lps { density, .. }
            | MaterialDeck::Correspondence { density, .. } => *density,
        }
    }
    pub fn fracture_energy(&self) -> Option<f64> {
        match self {
            MaterialDeck::Pmb {
                fracture_energy, ..
            }
            | MaterialDeck::Lps {
                fracture_energy, ..
            }
            | MaterialDeck::Correspondence {
                fracture_energy, ..
            } => *fracture_energy,
        }
    }
    pub fn critical_stretch(&self) -> Option<f64> {
        match self {
            MaterialDeck::Pmb {
                critical_stretch, ..
            }
            | MaterialDeck::Lps {
                critical_stretch, ..
            }
            | MaterialDeck::Correspondence {
                critical_stretch, ..
            } => *critical_stretch,
        }
    }
    /// The damage law (critical stretch when absent).
    pub fn damage(&self) -> DamageDeck {
        match self {
            MaterialDeck::Pmb { damage, .. }
            | MaterialDeck::Lps { damage, .. }
            | MaterialDeck::Correspondence { damage, .. } => {
                damage.clone().unwrap_or(DamageDeck::CriticalStretch {})
            }
        }
    }
    pub fn porosity(&self) -> Option<&PorosityDeck> {
        match self {
            MaterialDeck::Pmb { porosity, .. }
            | MaterialDeck::Lps { porosity, .. }
            | MaterialDeck::Correspondence { porosity, .. } => porosity.as_ref(),
        }
    }
}

/// A block: the nodes in a region (or, without a region, the nodes a point cloud gives this
/// id), with an optional material and horizon of their own. Later entries win.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BlockDeck {
    pub id: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region: Option<Shape>,
    /// Name of a `[materials.NAME]` table; absent: the deck's `[material]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<String>,
    /// Horizon δ (m) of the block's nodes (dual-horizon PD); absent: the discretization's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub horizon: Option<f64>,
}

/// A named node set selected by region.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeSetDeck {
    pub name: String,
    pub region: Shape,
}

/// `[[boundary_layers]]`: rows of nodes outside a face of the body's bounding box, bonded to
/// it like any node, for displacements prescribed as a local boundary condition.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundaryLayerDeck {
    /// The layer's node set.
    pub name: String,
    /// The face: "-x", "+x", "-y", "+y", "-z" or "+z".
    pub side: Side,
    /// Width (m); default: the horizon δ (the largest of the deck's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width: Option<f64>,
    /// Node spacing (m); default: the lattice spacing or mesh size (needed for meshes read
    /// from files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spacing: Option<f64>,
    /// The layer's bonds never break (default): it is a loading device, not material.
    #[serde(default = "default_true")]
    pub no_fail: bool,
}

/// A face of the body's bounding box.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Side {
    #[serde(rename = "-x")]
    MinusX,
    #[serde(rename = "+x")]
    PlusX,
    #[serde(rename = "-y")]
    MinusY,
    #[serde(rename = "+y")]
    PlusY,
    #[serde(rename = "-z")]
    MinusZ,
    #[serde(rename = "+z")]
    PlusZ,
}

impl Side {
    /// The axis normal to the face and whether the face is at its positive end.
    pub fn axis_and_end(self) -> (usize, bool) {
        match self {
            Side::MinusX => (0, false),
            Side::PlusX => (0, true),
            Side::MinusY => (1, false),
            Side::PlusY => (1, true),
            Side::MinusZ => (2, false),
            Side::PlusZ => (2, true),
        }
    }
}

/// Displacement component.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Component {
    X,
    Y,
    Z,
}

impl Component {
    pub fn index(self) -> usize {
        match self {
            Component::X => 0,
            Component::Y => 1,
            Component::Z => 2,
        }
    }
}

/// Prescribed displacement (m) or velocity (m/s) `value · time(t)` of one component; with a
/// `gradient`, `(value + gradient · (x − origin)) · time(t)` at each node's reference position
/// x (a load introduced unevenly: seed 004 Eq. 2's m_l).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundaryDeck {
    pub set: String,
    pub kind: Kinematic,
    pub component: Component,
    pub value: f64,
    #[serde(default)]
    pub time: TimeFunction,
    /// Change of the value per metre along each axis (one component per dimension).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gradient: Option<Vec<f64>>,
    /// Where the gradient's term vanishes (m); absent: the origin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin: Option<Vec<f64>>,
}

/// `[[stages]]`: a stage after the deck's own. Its solver is its own; boundary conditions,
/// loads and no-fail sets it leaves out are those of the stage before it. The clock runs on:
/// time functions keep their time, and `end_time` counts from the stage's start.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageDeck {
    /// A name for the summary and `stages.csv` (default: the stage's number).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub name: String,
    pub solver: SolverDeck,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub boundary_conditions: Option<Vec<BoundaryDeck>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loads: Option<Vec<LoadDeck>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub no_fail: Option<Vec<String>>,
    /// Steps between history rows in this stage (default: as for a one-stage run of its
    /// solver, unless `[output] history_interval` sets one for every stage).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub history_interval: Option<u64>,
}

/// Distributed loads on a node set.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum LoadDeck {
    /// Body force density (N/m³).
    BodyForce {
        set: String,
        value: Vec<f64>,
        #[serde(default)]
        time: TimeFunction,
    },
    /// Traction (Pa) over a surface of `area` (m²), applied as a body force spread over the
    /// volume of the set (the boundary layer).
    Traction {
        set: String,
        value: Vec<f64>,
        area: f64,
        #[serde(default)]
        time: TimeFunction,
    },
}

/// Initial velocity field on a node set (`all` for every node):
/// v(x) = value + gradient · (x − origin), m/s.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialVelocityDeck {
    pub set: String,
    pub value: Vec<f64>,
    /// ∂v_a/∂x_b (1/s), row a; absent: a uniform velocity.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gradient: Option<Vec<Vec<f64>>>,
    /// Point where v = value (m); default the origin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin: Option<Vec<f64>>,
}

/// The solver.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum SolverDeck {
    /// Explicit velocity-Verlet dynamics.
    Explicit {
        /// Number of steps; give this or `end_time`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        steps: Option<u64>,
        /// Simulated duration (s); give this or `steps`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        end_time: Option<f64>,
        /// Fixed time step (s); if absent, `safety_factor ×` the stable estimate.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        dt: Option<f64>,
        #[serde(default = "default_safety")]
        safety_factor: f64,
        /// Viscous damping coefficient η (1/s).
        #[serde(default)]
        damping: f64,
        /// Adaptive time step (seed 004 §5); absent: a fixed dt.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        adaptive: Option<AdaptiveDtDeck>,
    },
    /// Quasi-static loading: the load parameter t goes from 0 to `end_time` in `load_steps`
    /// equal steps (boundary conditions and loads are evaluated at t_k = k·end_time/load_steps);
    /// each step is relaxed to equilibrium, then bonds break and the body is re-equilibrated
    /// until none breaks (seed 001 Appendix B).
    QuasiStatic {
        load_steps: u64,
        /// The load parameter at the last step (default 1: ramps of duration 1 reach their full
        /// value at the end).
        #[serde(default = "default_one")]
        end_time: f64,
        #[serde(default)]
        method: QuasiStaticMethod,
        /// How ADR estimates its damping (absent: "local", and the resolved deck leaves it
        /// out, so that the decks and checkpoints of runs before the key stay the same).
        #[serde(default, skip_serializing_if = "AdrDampingDeck::is_local")]
        adr_damping: AdrDampingDeck,
        /// Conjugate gradients' preconditioner (absent: "jacobi", left out of the resolved
        /// deck like `adr_damping`).
        #[serde(default, skip_serializing_if = "PreconditionerDeck::is_jacobi")]
        preconditioner: PreconditionerDeck,
        /// Relative residual of an equilibrium: out-of-balance force over the loading forces.
        #[serde(default = "default_qs_tolerance")]
        tolerance: f64,
        /// Iterations allowed per relaxation.
        #[serde(default = "default_qs_iterations")]
        max_iterations: u64,
        /// Multiplies the fictitious mass of adaptive dynamic relaxation (1: the Gershgorin
        /// bound; larger is slower and safer).
        #[serde(default = "default_one")]
        mass_factor: f64,
        /// Relaxations allowed per load step (break bonds, re-equilibrate).
        #[serde(default = "default_qs_equilibria")]
        max_equilibria: u32,
        /// A load step breaking more bonds than this is undone and split in two (adaptive load
        /// stepping); absent: never split.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_broken_bonds: Option<u64>,
        /// How many times a load step may be halved.
        #[serde(default = "default_qs_splits")]
        max_splits: u32,
        /// The stage ends after the first load step whose equilibrium stores less than this
        /// fraction of the work done on the body (it has broken through); absent: it runs
        /// all its load steps.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        stop_when_stored_below: Option<f64>,
    },
}

/// `[solver.adaptive]`: the adaptive explicit time step of seed 004 §5 (defaults of the
/// authors' Peridigm code).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdaptiveDtDeck {
    /// N_b^m: a node losing more bonds than this in a step rejects the step.
    #[serde(default = "default_max_broken_per_node")]
    pub max_broken_per_node: u32,
    /// N_b^s: a step in which every node loses at most this many is quiet.
    #[serde(default = "default_stable_broken_per_node")]
    pub stable_broken_per_node: u32,
    /// step_d: steps since the last change before dt may grow.
    #[serde(default = "default_stable_steps")]
    pub stable_steps: u64,
    /// t_reduce.
    #[serde(default = "default_reduce")]
    pub reduce: f64,
    /// t_raise.
    #[serde(default = "default_raise")]
    pub raise: f64,
    /// t_min (s); default the initial dt / 5.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_dt: Option<f64>,
    /// t_max (s); default the initial dt (never above the stable time step).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_dt: Option<f64>,
}

fn default_max_broken_per_node() -> u32 {
    4
}
fn default_stable_broken_per_node() -> u32 {
    1
}
fn default_stable_steps() -> u64 {
    4
}
fn default_reduce() -> f64 {
    0.5
}
fn default_raise() -> f64 {
    1.2
}

/// How a quasi-static step finds equilibrium.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QuasiStaticMethod {
    /// Adaptive dynamic relaxation (Kilic & Madenci 2010).
    #[default]
    Adr,
    /// Nonlinear conjugate gradients (Polak–Ribière, secant line search) on the potential
    /// energy: convex models only (no softening law).
    Ncg,
}

/// How adaptive dynamic relaxation estimates its damping coefficient.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AdrDampingDeck {
    /// Kilic & Madenci's local Rayleigh quotient of the displacements.
    #[default]
    Local,
    /// The Rayleigh quotient of the last increment.
    Increment,
}

impl AdrDampingDeck {
    fn is_local(&self) -> bool {
        *self == AdrDampingDeck::Local
    }
}

/// How conjugate gradients precondition their residual.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PreconditionerDeck {
    /// The inverse of the diagonal stiffness bound.
    #[default]
    Jacobi,
    /// Jacobi plus a coarse grid's correction (`solver::coarse_space`).
    TwoLevel,
}

impl PreconditionerDeck {
    fn is_jacobi(&self) -> bool {
        *self == PreconditionerDeck::Jacobi
    }
}

fn default_qs_tolerance() -> f64 {
    1e-6
}
fn default_qs_iterations() -> u64 {
    200_000
}
fn default_qs_equilibria() -> u32 {
    1000
}
fn default_qs_splits() -> u32 {
    8
}

fn is_dual(coupling: &HorizonCoupling) -> bool {
    *coupling == HorizonCoupling::Dual
}

fn default_safety() -> f64 {
    0.8
}

/// What to write and how often.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputDeck {
    /// Steps between history rows (0: only first and last); default 10 for explicit
    /// dynamics, 1 (every load step) for quasi-static runs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub history_interval: Option<u64>,
    /// Number of field snapshots over the run (VTU, and the PNG maps), besides the initial one.
    #[serde(default = "default_snapshots")]
    pub snapshots: u64,
    /// Write PNG field maps of every snapshot (in 3D of a slice); `false` turns all maps off.
    #[serde(default = "default_true")]
    pub png: bool,
    /// The fields drawn as maps when `png` is on.
    #[serde(default = "default_maps")]
    pub maps: Vec<MapField>,
    /// The plane a 3D run's maps show; absent: the body's mid-plane along z.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map_slice: Option<MapSliceDeck>,
    /// Write PNG plots of the history (energies, load–displacement, openings, time step) at
    /// the end of the run.
    #[serde(default = "default_true")]
    pub plots: bool,
    /// Openings between two points (e.g. the crack-mouth opening displacement, CMOD),
    /// recorded in the history.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub openings: Vec<OpeningDeck>,
    /// Points whose velocity and displacement (of the nearest node) the history records.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub probes: Vec<ProbeDeck>,
    /// Write `checkpoint.bin` (the state to restart from) at every snapshot.
    #[serde(default = "default_true")]
    pub checkpoint: bool,
    /// Steps between further checkpoints, besides those at snapshots.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub checkpoint_interval: Option<u64>,
    /// How the VTU snapshots are written: one file of the whole body, or one piece per rank
    /// and a `.pvtu` that ties them (a distributed run then never gathers them on rank 0).
    #[serde(default, skip_serializing_if = "Pieces::is_gathered")]
    pub pieces: Pieces,
}

/// `[output] pieces`: one VTU file per snapshot, or one piece per rank and a `.pvtu`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Pieces {
    /// `fields/step_N.vtu`, the whole body (a distributed run gathers it on rank 0).
    #[default]
    Gathered,
    /// `fields/step_N.pvtu` and its pieces `fields/step_N_piece_R.vtu`, one per rank, each
    /// written by its rank from its own nodes.
    PerRank,
}

impl Pieces {
    fn is_gathered(&self) -> bool {
        *self == Pieces::Gathered
    }
}

/// A nodal field drawn as a PNG map; its deck name is also its file name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MapField {
    /// Damage index (-).
    Damage,
    /// Strain energy density W_i (J/m³).
    StrainEnergy,
    /// Displacement magnitude |u| (m).
    Displacement,
}

impl MapField {
    /// The deck name, used for the file names `<name>.png` and `images/<name>_step_N.png`.
    pub fn name(self) -> &'static str {
        match self {
            MapField::Damage => "damage",
            MapField::StrainEnergy => "strain_energy",
            MapField::Displacement => "displacement",
        }
    }
}

/// `[output] map_slice = { axis = "z", at = 1e-3 }`: the plane of a 3D run's maps.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapSliceDeck {
    /// The plane's normal.
    #[serde(default = "default_slice_axis")]
    pub axis: Component,
    /// The plane's coordinate along `axis` (m); absent: the middle of the body's extent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at: Option<f64>,
}

fn default_slice_axis() -> Component {
    Component::Z
}

/// `[[output.openings]]`: the change of distance between the nodes nearest two points.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpeningDeck {
    pub name: String,
    /// The two points (m), `dimension` coordinates each.
    pub between: [Vec<f64>; 2],
}

/// `[[output.probes]]`: the velocity and displacement of the node nearest a point.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeDeck {
    pub name: String,
    /// The point (m), `dimension` coordinates.
    pub at: Vec<f64>,
}

fn default_snapshots() -> u64 {
    10
}
fn default_true() -> bool {
    true
}
fn default_maps() -> Vec<MapField> {
    vec![MapField::Damage]
}

impl Default for OutputDeck {
    fn default() -> Self {
        OutputDeck {
            history_interval: None,
            snapshots: default_snapshots(),
            png: true,
            maps: default_maps(),
            map_slice: None,
            plots: true,
            openings: Vec::new(),
            probes: Vec::new(),
            checkpoint: true,
            checkpoint_interval: None,
            pieces: Pieces::Gathered,
        }
    }
}

/// `[analysis]`: what to measure on the damage field while the run goes on.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnalysisDeck {
    /// Crack-tip tracking and crack speed (`crack_tip.csv`, `crack_speed.csv`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crack_tip: Option<CrackTipDeck>,
    /// The crack path and its forks, 2D (`crack_path.csv`, `branching.csv`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crack_path: Option<CrackPathDeck>,
    /// The crack as a surface and its area, 3D (`crack_surface.csv`, `crack_surface.vtu`,
    /// `crack_area.csv`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crack_surface: Option<CrackSurfaceDeck>,
    /// How many cracks cross given lines, 2D (`crack_crossings.csv`,
    /// `crack_crossing_points.csv`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crack_crossings: Option<CrackCrossingsDeck>,
    /// The nodes' displacement against an analytic solution (`displacement_error.csv`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub displacement_error: Option<DisplacementErrorDeck>,
}

/// `[analysis.displacement_error]`: every `interval` steps, per node set, the RMS and the
/// largest magnitude of the nodes' displacement less an analytic solution's (seed 003 Figs.
/// 9–10).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DisplacementErrorDeck {
    pub solution: ExactSolutionDeck,
    /// The node sets compared (each set's nodes on the solution's domain).
    #[serde(default = "default_error_sets")]
    pub sets: Vec<String>,
    /// Steps between rows (the last step always has one).
    #[serde(default = "default_tip_interval")]
    pub interval: u64,
}

impl ExactSolutionDeck {
    /// The bar, its waves at `wave_speed` unless the deck gives one.
    pub fn bar(&self, wave_speed: f64) -> crate::analysis::FixedFreeBar {
        let ExactSolutionDeck::FixedFreeBar {
            strain,
            length,
            fixed_end,
            release,
            wave_speed: given,
        } = *self;
        crate::analysis::FixedFreeBar {
            strain,
            length,
            fixed_end,
            release,
            wave_speed: given.unwrap_or(wave_speed),
        }
    }
}

fn default_error_sets() -> Vec<String> {
    vec!["all".to_string()]
}

/// An analytic displacement field.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum ExactSolutionDeck {
    /// A bar along x, fixed at `fixed_end` and free at `fixed_end + length`, released at time
    /// `release` from the uniform strain `strain` at rest (seed 003 §4.1, Eq. 15); its waves
    /// travel at `wave_speed` (absent: the model's P-wave speed, a strip held across its
    /// width carrying uniaxial strain).
    FixedFreeBar {
        strain: f64,
        length: f64,
        #[serde(default)]
        fixed_end: f64,
        #[serde(default)]
        release: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        wave_speed: Option<f64>,
    },
}

/// `[analysis.crack_crossings]` (2D): every `interval` steps, the number of separate cracks
/// crossing each of `lines` (damaged nodes in a strip about the line, split at gaps > `link`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CrackCrossingsDeck {
    /// A node is damaged when its damage exceeds this.
    #[serde(default = "default_tip_threshold")]
    pub threshold: f64,
    /// Steps between counts (the last step is always counted).
    #[serde(default = "default_tip_interval")]
    pub interval: u64,
    /// Damaged nodes further apart along a line than this are two cracks (m); absent: three
    /// times the smallest cell size.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub link: Option<f64>,
    #[serde(default)]
    pub lines: Vec<CrossingLineDeck>,
}

/// One line of `[analysis.crack_crossings]`: a segment and the strip searched about it.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CrossingLineDeck {
    /// Its column in `crack_crossings.csv`.
    pub name: String,
    /// Start of the segment (m).
    pub from: Vec<f64>,
    /// End of the segment (m).
    pub to: Vec<f64>,
    /// Full width of the strip searched (m); absent: the link distance.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width: Option<f64>,
}

/// `[analysis.crack_surface]` (3D): the crack area from the broken bonds every `interval`
/// steps, with the dissipation rate Γ = dE_diss/dA (seed 002 Eq. 13), and at the end the
/// crack surface binned on square cells of side `bin_width` in the plane normal to `axis`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CrackSurfaceDeck {
    /// The crack's mean normal ("x", "y" or "z").
    pub axis: Component,
    /// Cell side (m); absent: twice the smallest cell size.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bin_width: Option<f64>,
    /// Steps between area samples (the last step is always sampled).
    #[serde(default = "default_tip_interval")]
    pub interval: u64,
}

/// `[analysis.crack_path]` (2D): the crack as a polyline binned along `axis` at the end of the
/// run, compared with a `reference` path when given (seed 003 §4: Pearson correlation over 52
/// samples); forks of the damaged region looked for every `interval` steps.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CrackPathDeck {
    /// The axis the crack runs along (x or y); forks are looked for along +axis.
    #[serde(default = "default_path_axis")]
    pub axis: Component,
    /// A node is damaged when its damage exceeds this.
    #[serde(default = "default_tip_threshold")]
    pub threshold: f64,
    /// Bin width along the axis (m); absent: twice the smallest cell size.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bin_width: Option<f64>,
    /// Reference path, points (x, y) in m.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub reference: Vec<Vec<f64>>,
    /// Sample points of the comparison (seed 003: 52).
    #[serde(default = "default_path_samples")]
    pub samples: usize,
    /// Steps between fork checks (the last step is always checked).
    #[serde(default = "default_tip_interval")]
    pub interval: u64,
    /// Damaged nodes closer than this are one region, and the bands across the axis are this
    /// wide (m); absent: three times the smallest cell size.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub link: Option<f64>,
    /// Bands a branch's angle is fitted over.
    #[serde(default = "default_fit_bands")]
    pub fit_bands: usize,
    /// Only the damaged nodes inside this shape count (absent: the whole body): the crack
    /// the analysis follows, apart from others elsewhere in the body.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region: Option<Shape>,
}

fn default_path_axis() -> Component {
    Component::X
}
fn default_path_samples() -> usize {
    52
}
fn default_fit_bands() -> usize {
    3
}

/// `[analysis.crack_tip]`: the tip is the damaged node furthest along `direction` (seed 000
/// App. 2), sampled every `interval` steps; the speed is a forward difference over `window`
/// samples.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CrackTipDeck {
    /// Propagation direction (one component per dimension, non-zero; normalised).
    pub direction: Vec<f64>,
    /// A node is damaged when its damage exceeds this (seed 000 App. 2: 0.35; seed 002: 0.4).
    #[serde(default = "default_tip_threshold")]
    pub threshold: f64,
    /// Steps between samples (the last step is always sampled).
    #[serde(default = "default_tip_interval")]
    pub interval: u64,
    /// Samples spanned by one speed difference (seed 000 App. 2: 30).
    #[serde(default = "default_tip_window")]
    pub window: usize,
    /// Search boxes of the branches of a branching crack (seed 000 Fig. 22); none: one branch
    /// "crack" over the whole body.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub branches: Vec<BranchDeck>,
}

/// One crack branch: its name in the output and the box its tip is searched in.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BranchDeck {
    pub name: String,
    /// Lower corner of the search box (m).
    pub min: Vec<f64>,
    /// Upper corner of the search box (m).
    pub max: Vec<f64>,
}

fn default_tip_threshold() -> f64 {
    0.35
}
fn default_tip_interval() -> u64 {
    10
}
fn default_tip_window() -> usize {
    30
}
