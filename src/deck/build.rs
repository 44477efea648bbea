//! Deck → model: body, bonds, loading, and the calibrated materials and damage laws.

use super::grids;
use super::schema::*;
// The solver settings moved to their own file; their old paths still work.
pub use super::solver_settings::{settings_of, solver_settings, SolverSettings};
use super::validate::dimensionality;
use super::{DeckError, DeckIssue, LoadedDeck};
use crate::body::Body;
use crate::bonds::search::{build_bonds, estimate_bonds};
use crate::bonds::{Bonds, PartialVolume, Quadrature};
use crate::damage::critical_energy::UniformCriticalEnergy;
use crate::damage::mixed::BlockLaw;
use crate::damage::porosity::Porosity;
use crate::damage::softening::{Shape as SofteningShape, SofteningParameters};
use crate::damage::DamageLaw;
use crate::damage::{
    history_words, BondForce, CriticalEnergy, CriticalStretch, Damage, MixedDamage, PerNode,
    Softening,
};
use crate::discretize::gmsh::read_gmsh;
use crate::discretize::{boundary_layer, lattice, NodeCloud};
use crate::geometry::point_cloud::read_point_cloud;
use crate::loading::{InitialVelocity, Loading};
use crate::material::correspondence::ZeroEnergyControl;
use crate::material::mixed::BlockMaterial;
use crate::material::pmb::HorizonCoupling;
use crate::material::surface_correction::{
    corrected, surface_factors, SurfaceCorrection, SurfaceFactors,
};
use crate::material::{Correspondence, Dimensionality, Elasticity, Lps, Mixed, Pmb};
use crate::math::{extent, vector_from_slice, Vector};
use crate::memory;
use crate::plot::map_nodes::MapNodes;
use crate::solver::ranks::Share;
use serde::Serialize;
use std::collections::BTreeMap;

/// The discretized body with its families and loading.
pub struct Model<const D: usize> {
    pub body: Body<D>,
    pub bonds: Bonds,
    pub loading: Loading<D>,
    pub rule: PartialVolume,
    /// Horizon δ of the discretization (m); blocks may give their nodes another.
    pub horizon: f64,
    /// Smallest cell size Δx (m).
    pub spacing: f64,
    pub dimensionality: Dimensionality,
    /// (name, initial velocity) pairs still to apply to the state.
    pub initial_velocities: Vec<InitialVelocity<D>>,
    /// Index into `materials` of each node.
    pub material_of: Vec<u16>,
    /// Deck key of each material in use: "material", or "materials.NAME".
    pub materials: Vec<String>,
    /// Time spent generating the grid and searching the bonds.
    pub build_time: std::time::Duration,
    /// The random pores' realisation (`pores.txt`), when the deck has pores.
    pub pores: Option<String>,
    /// The `[[stages]]` after the deck's own (whose loading and no-fail flags are above).
    pub stages: Vec<super::stages::StagePlan<D>>,
}

/// The calibrated model of a deck's material(s): what `run.rs` dispatches on.
#[derive(Debug, Clone)]
pub enum MaterialChoice {
    Pmb(Pmb),
    Lps(Lps),
    Correspondence(Correspondence),
    Mixed(Mixed),
}

/// Materials and damage laws, calibrated for the body's horizons.
#[derive(Debug, Clone)]
pub struct Constitution {
    pub material: MaterialChoice,
    pub damage: Damage,
    /// What `check` and `resolved.toml` report, one per material in use.
    pub reports: Vec<MaterialReport>,
    /// IH-PD pre-broken bonds to draw, per material index.
    pub porosity: Vec<(u16, Porosity)>,
    /// Surface-correction factors, when the deck asks for them.
    pub surface: Option<SurfaceFactors>,
}

/// One material as calibrated (at the discretization's horizon when horizons vary).
#[derive(Debug, Clone, Serialize, Default)]
pub struct MaterialReport {
    /// Deck key: "material" or "materials.NAME".
    pub key: String,
    pub model: String,
    pub damage: String,
    pub nodes: usize,
    /// Young's modulus (Pa) and density (kg/m³) in use (solid phase with porosity).
    pub youngs_modulus: f64,
    pub poisson_ratio: f64,
    pub density: f64,
    /// Horizon range of the material's nodes (m).
    pub horizon_min: f64,
    pub horizon_max: f64,
    /// PMB micromodulus as the papers write it (2D: per unit thickness).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub micromodulus: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub critical_stretch: Option<f64>,
    /// Fracture energy G0 (J/m²) the damage law is calibrated to (solid phase with porosity,
    /// seed 001 Eq. 18); none when the deck gives no G0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fracture_energy: Option<f64>,
    /// Critical bond energy w_c (J/m⁶).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub critical_energy: Option<f64>,
    /// Softening: s1, s2 (trilinear kink) and the breaking stretch.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peak_stretch: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kink_stretch: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub breaking_stretch: Option<f64>,
    /// Bonds broken before loading (IH-PD porosity).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prebroken_bonds: Option<usize>,
    /// What the user should know about this calibration.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// The deck's random pores, if any, with their record, or an error at `discretization.pores`.
fn deck_pores(
    ld: &LoadedDeck,
    shape: &crate::geometry::Shape,
    dim: usize,
    pores: &Option<PoresDeck>,
) -> Result<(Vec<crate::geometry::pores::Pore>, Option<String>), DeckError> {
    match pores {
        None => Ok((Vec::new(), None)),
        Some(p) => grids::pores_of(shape, dim, p)
            .map(|(pores, text)| (pores, Some(text)))
            .map_err(|e| ld.locate(vec![DeckIssue::new("discretization.pores", e)])),
    }
}

/// The largest point state, per-node memo and previous own-half matrices of any model
/// (correspondence in 3D): what the memory estimate assumes per node before the model is
/// built.
const LARGEST_NODE_STATE: usize = std::mem::size_of::<
    crate::material::correspondence::CorrespondencePoint<3>,
>() + crate::material::stabilisation_memo::SLOT_BYTES
    + 8 * <crate::material::correspondence::Correspondence as crate::material::Material<3>>::NODE_MATRIX_WORDS;

/// Builds the body, bonds and loading of a validated deck, refusing (before spending it) more
/// memory than the machine has.
pub fn build_model<const D: usize>(ld: &LoadedDeck) -> Result<Model<D>, DeckError> {
    build_model_with(ld, |body, families| {
        families.fits(ld, &body)?;
        let bonds = build_bonds(&body, families.rule, &ld.deck.precracks);
        Ok(Part {
            body,
            bonds,
            globals: None,
        })
    })
}

/// The body a model is built on and its families, as `build_model_with`'s `part` makes them.
pub struct Part<const D: usize> {
    pub body: Body<D>,
    pub bonds: Bonds,
    /// The global index of each node of `body` when it is a part of the deck's body (a
    /// process's share of a distributed run); `None`: the whole body.
    pub globals: Option<Vec<u32>>,
}

/// What `build_model_with`'s `part` knows of the bonds to build.
pub struct Families {
    pub rule: PartialVolume,
    /// Bytes per directed bond the model will need.
    pub bytes_per_bond: usize,
    /// Bytes per node (the largest model's node state).
    pub bytes_per_node: usize,
}

impl Families {
    /// Refuses a body whose bonds would not fit in the memory the machine has.
    pub fn fits<const D: usize>(&self, ld: &LoadedDeck, body: &Body<D>) -> Result<(), DeckError> {
        memory::Estimate::new(
            body.len() as f64,
            estimate_bonds(body, self.rule),
            self.bytes_per_node,
            self.bytes_per_bond,
        )
        .fits(memory::available_bytes())
        .map_err(|e| {
            let at = match ld.deck.discretization {
                Discretization::Lattice {
                    horizon_ratio: Some(_),
                    ..
                } => "discretization.horizon_ratio",
                _ => "discretization.horizon",
            };
            ld.locate(vec![DeckIssue::new(at, e)])
        })
    }
}

/// `build_model` with the families built by `part` from the whole body (its node sets and
/// no-fail flags in place): all of them, or (a distributed run) one process's share, on the
/// part of the body it returns. The loading, stages and initial velocities are built on that
/// part.
pub fn build_model_with<const D: usize>(
    ld: &LoadedDeck,
    part: impl FnOnce(Body<D>, &Families) -> Result<Part<D>, DeckError>,
) -> Result<Model<D>, DeckError> {
    let started = std::time::Instant::now();
    let deck = &ld.deck;
    let dimensionality = dimensionality(deck).expect("validated deck");
    let thickness = deck.thickness.unwrap_or(1.0);
    let available = memory::available_bytes();
    let per_node = memory::bytes_per_node(D, LARGEST_NODE_STATE);
    let per_grid_node = memory::grid_bytes_per_node(D);
    let mut pores_record = None;
    let mut record_pores = |(pores, text)| {
        pores_record = text;
        pores
    };
    let (cloud, horizon, rule, mesh_sets) = match &deck.discretization {
        Discretization::Lattice {
            shape,
            spacing,
            horizon,
            horizon_ratio,
            partial_volume,
            refine,
            pores,
            ..
        } => {
            let h = horizon.unwrap_or_else(|| horizon_ratio.unwrap_or(3.0) * spacing);
            let at = |e: String| ld.locate(vec![DeckIssue::new("discretization.shape", e)]);
            let pores = record_pores(deck_pores(ld, shape, D, pores)?);
            // Each level of refinement can at most multiply the count by 2^D.
            let deepest = refine.iter().map(|r| r.levels).max().unwrap_or(0);
            let cells = lattice::cell_count(shape, D, *spacing).map_err(at)?
                * (1u64 << (D as u32 * deepest.min(8))) as f64;
            memory::Estimate::new(cells, 0.0, per_grid_node, 0)
                .fits(available)
                .map_err(|e| ld.locate(vec![DeckIssue::new("discretization.spacing", e)]))?;
            let cloud =
                grids::lattice_grid(shape, D, *spacing, thickness, refine, &pores).map_err(at)?;
            (cloud, h, *partial_volume, BTreeMap::new())
        }
        Discretization::FreeMesh {
            shape,
            size,
            horizon,
            horizon_ratio,
            partial_volume,
            cells,
            pores,
            ..
        }
        | Discretization::Nbnug {
            shape,
            size,
            horizon,
            horizon_ratio,
            partial_volume,
            cells,
            pores,
            ..
        } => {
            let h = horizon.unwrap_or_else(|| horizon_ratio.unwrap_or(3.0) * size);
            let at = |e: String| ld.locate(vec![DeckIssue::new("discretization.shape", e)]);
            // A triangle of the mesh covers about 0.2 size² or more.
            let (lo, hi) = shape
                .bounding_box()
                .ok_or_else(|| at("the shape must be bounded".into()))?;
            let cells_estimate = (hi[0] - lo[0]) * (hi[1] - lo[1]) / (0.2 * size * size);
            memory::Estimate::new(cells_estimate, 0.0, per_grid_node, 0)
                .fits(available)
                .map_err(|e| ld.locate(vec![DeckIssue::new("discretization.size", e)]))?;
            let pores = record_pores(deck_pores(ld, shape, D, pores)?);
            let cloud = match &deck.discretization {
                Discretization::Nbnug { padding, .. } => grids::nbnug_grid(
                    shape,
                    *size,
                    padding.unwrap_or(h),
                    thickness,
                    *cells,
                    &pores,
                ),
                _ => grids::free_mesh_grid(shape, *size, thickness, *cells, &pores),
            }
            .map_err(at)?;
            (cloud, h, *partial_volume, BTreeMap::new())
        }
        Discretization::PointCloud {
            file,
            horizon,
            partial_volume,
            ..
        } => {
            let path = ld.base_dir().join(file);
            let pc = read_point_cloud(&path, D).map_err(|e| {
                ld.locate(vec![DeckIssue::new("discretization.file", e.to_string())])
            })?;
            (
                NodeCloud::from_measures(pc.positions, &pc.volumes, pc.blocks, D, thickness),
                *horizon,
                *partial_volume,
                BTreeMap::new(),
            )
        }
        Discretization::Gmsh {
            file,
            horizon,
            partial_volume,
            ..
        } => {
            let path = ld.base_dir().join(file);
            let mesh = read_gmsh(&path, D).map_err(|e| {
                ld.locate(vec![DeckIssue::new("discretization.file", e.to_string())])
            })?;
            (
                NodeCloud::from_measures(mesh.positions, &mesh.measures, mesh.blocks, D, thickness),
                *horizon,
                *partial_volume,
                mesh.node_sets,
            )
        }
    };
    if cloud.is_empty() {
        let at = if matches!(deck.discretization, Discretization::Lattice { .. }) {
            "discretization.shape"
        } else {
            "discretization"
        };
        return Err(ld.locate(vec![DeckIssue::new(
            at,
            "the discretization produced no nodes; check the shape and spacing",
        )]));
    }
    let mesh_set_names: Vec<String> = mesh_sets.keys().cloned().collect();
    let (cloud, mesh_sets) = with_boundary_layers::<D>(ld, cloud, mesh_sets, horizon)?;
    let mut body = Body::<D>::from_cloud_with_sets(cloud, mesh_sets, horizon, thickness);
    // A refined lattice with a horizon ratio: δ_i = m Δx_i (seed 003), dual-horizon PD.
    if let Discretization::Lattice {
        horizon_ratio: Some(m),
        refine,
        ..
    } = &deck.discretization
    {
        if !refine.is_empty() {
            for i in 0..body.len() {
                body.horizons[i] = m * body.cell_sizes[i];
            }
        }
    }
    let spacing = body.min_cell_size();
    if horizon < spacing {
        return Err(ld.locate(vec![DeckIssue::new("discretization.horizon", format!("horizon {horizon} m is smaller than the smallest cell {spacing} m; expected δ/Δx ≥ 1, typically 3 to 4"))]));
    }
    let (material_of, materials) = assign_blocks(ld, &mut body)?;
    let mut issues = Vec::new();
    if mesh_set_names.iter().any(|n| n == "all") {
        issues.push(DeckIssue::new(
            "discretization.file",
            "the mesh has a physical group named \"all\", a reserved node set name (every node); rename the group",
        ));
    }
    for (k, set) in deck.node_sets.iter().enumerate() {
        if mesh_set_names.contains(&set.name) {
            issues.push(DeckIssue::new(
                &format!("node_sets[{k}].name"),
                format!(
                    "node set {:?} is also a named physical group of the mesh; rename one of them",
                    set.name
                ),
            ));
            continue;
        }
        if body.add_node_set(&set.name, &set.region) == 0 {
            issues.push(DeckIssue::new(
                &format!("node_sets[{k}].region"),
                format!(
                    "node set {:?} selects no nodes; check its region against the body",
                    set.name
                ),
            ));
        }
    }
    unknown_sets(deck, &body, &mut issues);
    map_slice_cuts_body(deck, &body, &mut issues);
    exact_solution_covers_sets(deck, &body, &mut issues);
    if !issues.is_empty() {
        return Err(ld.locate(issues));
    }
    let layers_holding = deck.boundary_layers.iter().filter(|l| l.no_fail);
    for name in deck.no_fail.iter().chain(layers_holding.map(|l| &l.name)) {
        let nodes = body.node_set(name).expect("validated set name");
        body.mark_no_fail(&nodes);
    }
    let history = if materials.len() > 1 {
        let laws: Vec<_> = deck
            .materials_in_use(&materials)
            .map(|m| m.damage())
            .collect();
        crate::damage::mixed::history_words(
            laws.iter().any(|d| {
                matches!(
                    d,
                    DamageDeck::Bilinear { .. } | DamageDeck::Trilinear { .. }
                )
            }),
            laws.iter()
                .any(|d| matches!(d, DamageDeck::CriticalEnergy { .. })),
            // A body of central models only runs the central mixed form.
            !deck
                .materials_in_use(&materials)
                .any(|m| matches!(m, MaterialDeck::Correspondence { .. })),
        )
    } else {
        let m = deck.material_at(&materials[0]);
        // PMB under a critical energy stores no work record when w_c is one value, as it is
        // when every node has the same horizon (else the estimate counts the record).
        let same_horizon = body.horizons.iter().all(|&h| h == body.horizons[0]);
        let force = match m {
            // One w_c (one horizon): each entry keeps its own half of the work.
            MaterialDeck::Correspondence { .. } if same_horizon => BondForce::NodeLinear,
            MaterialDeck::Correspondence { .. } => BondForce::Vector,
            MaterialDeck::Pmb { .. } if same_horizon => BondForce::Linear,
            _ => BondForce::Central,
        };
        damage_history_words(&m.damage(), force)
    };
    let relaxation = deck.relaxation_bytes_per_bond(8 * history);
    let exact = if rule == PartialVolume::Exact { 2 } else { 0 };
    let families = Families {
        rule,
        bytes_per_bond: memory::bytes_per_bond(
            Bonds::BYTES_PER_BOND
                + crate::solver::damage_cache::BYTES_PER_BOND
                + 8 * history
                + exact
                + relaxation,
        ),
        bytes_per_node: per_node,
    };
    // The stages' no-fail flags of every node, the ghosts' too (a part's node sets hold its
    // owned nodes only, but a bond reads the flags of both its ends).
    let stage_no_fail = super::stages::stage_no_fail(deck, &body);
    let traction_volumes = super::stages::traction_volumes(deck, &body);
    let Part {
        body,
        bonds,
        globals,
    } = part(body, &families)?;
    let (material_of, stage_no_fail) = match globals {
        Some(g) => {
            let local = |whole: &[bool]| g.iter().map(|&i| whole[i as usize]).collect();
            (
                g.iter().map(|&i| material_of[i as usize]).collect(),
                stage_no_fail.iter().map(|m| local(m)).collect(),
            )
        }
        None => (material_of, stage_no_fail),
    };

    let loading = super::stages::loading(
        &body,
        &deck.boundary_conditions,
        &deck.loads,
        &deck.solver,
        &traction_volumes,
    );
    let stages = super::stages::further_stages(deck, &body, stage_no_fail, &traction_volumes);
    let initial_velocities = deck
        .initial_velocities
        .iter()
        .map(|iv| InitialVelocity {
            nodes: body.node_set(&iv.set).expect("validated set name"),
            value: vector_from_slice::<D>(&iv.value),
            gradient: iv
                .gradient
                .as_ref()
                .map_or(nalgebra::SMatrix::zeros(), |g| {
                    nalgebra::SMatrix::from_fn(|a, b| g[a][b])
                }),
            origin: iv
                .origin
                .as_ref()
                .map_or(Vector::zeros(), |o| vector_from_slice::<D>(o)),
        })
        .collect();
    Ok(Model {
        build_time: started.elapsed(),
        body,
        bonds,
        loading,
        rule,
        horizon,
        spacing,
        dimensionality,
        initial_velocities,
        material_of,
        materials,
        pores: pores_record,
        stages,
    })
}

/// The cloud with the deck's fictitious boundary layers added, each a node set of its name.
fn with_boundary_layers<const D: usize>(
    ld: &LoadedDeck,
    mut cloud: NodeCloud,
    mut sets: BTreeMap<String, Vec<u32>>,
    horizon: f64,
) -> Result<(NodeCloud, BTreeMap<String, Vec<u32>>), DeckError> {
    let deck = &ld.deck;
    let grid_spacing = match &deck.discretization {
        Discretization::Lattice { spacing, .. } => Some(*spacing),
        Discretization::FreeMesh { size, .. } | Discretization::Nbnug { size, .. } => Some(*size),
        Discretization::PointCloud { .. } | Discretization::Gmsh { .. } => None,
    };
    // The widest horizon of the body: every node near the face then has a full family.
    let widest = deck
        .blocks
        .iter()
        .filter_map(|b| b.horizon)
        .fold(horizon, f64::max);
    let thickness = deck.thickness.unwrap_or(1.0);
    // Faces are those of the body alone, not of the layers added before: a mesh's are its
    // shape's (its cells follow the boundary), a lattice's or a file's those of its cells.
    let body_box = match &deck.discretization {
        Discretization::FreeMesh { shape, .. } | Discretization::Nbnug { shape, .. } => {
            let (lo, hi) = shape.bounding_box().expect("a meshed shape is bounded");
            let corner = |c: Vec<f64>| std::array::from_fn(|k| c.get(k).copied().unwrap_or(0.0));
            (corner(lo), corner(hi))
        }
        _ => boundary_layer::cell_box(&cloud, D),
    };
    for (k, layer) in deck.boundary_layers.iter().enumerate() {
        let (axis, positive) = layer.side.axis_and_end();
        let spacing = layer.spacing.or(grid_spacing).expect("validated spacing");
        let width = layer.width.unwrap_or(widest);
        let face = boundary_layer::Face { axis, positive };
        let nodes =
            boundary_layer::add_layer(&mut cloud, D, face, body_box, (width, spacing), thickness)
                .map_err(|e| ld.locate(vec![DeckIssue::new(&format!("boundary_layers[{k}]"), e)]))?;
        if sets.insert(layer.name.clone(), nodes).is_some() {
            return Err(ld.locate(vec![DeckIssue::new(
                &format!("boundary_layers[{k}].name"),
                format!(
                    "{:?} is also a named physical group of the mesh; rename one of them",
                    layer.name
                ),
            )]));
        }
    }
    Ok((cloud, sets))
}

/// Node set names the deck refers to but neither it nor the mesh defines (validation leaves
/// them to the build when the nodes come from a mesh).
fn unknown_sets<const D: usize>(deck: &Deck, body: &Body<D>, issues: &mut Vec<DeckIssue>) {
    let mut refs: Vec<(String, &str)> = Vec::new();
    for (k, name) in deck.no_fail.iter().enumerate() {
        refs.push((format!("no_fail[{k}]"), name));
    }
    for (k, bc) in deck.boundary_conditions.iter().enumerate() {
        refs.push((format!("boundary_conditions[{k}].set"), &bc.set));
    }
    for (k, load) in deck.loads.iter().enumerate() {
        let (LoadDeck::BodyForce { set, .. } | LoadDeck::Traction { set, .. }) = load;
        refs.push((format!("loads[{k}].set"), set));
    }
    for (k, iv) in deck.initial_velocities.iter().enumerate() {
        refs.push((format!("initial_velocities[{k}].set"), &iv.set));
    }
    for (s, stage) in deck.stages.iter().enumerate() {
        for (k, name) in stage.no_fail.iter().flatten().enumerate() {
            refs.push((format!("stages[{s}].no_fail[{k}]"), name));
        }
        for (k, bc) in stage.boundary_conditions.iter().flatten().enumerate() {
            refs.push((format!("stages[{s}].boundary_conditions[{k}].set"), &bc.set));
        }
        for (k, load) in stage.loads.iter().flatten().enumerate() {
            let (LoadDeck::BodyForce { set, .. } | LoadDeck::Traction { set, .. }) = load;
            refs.push((format!("stages[{s}].loads[{k}].set"), set));
        }
    }
    if let Some(e) = deck
        .analysis
        .as_ref()
        .and_then(|a| a.displacement_error.as_ref())
    {
        for (k, name) in e.sets.iter().enumerate() {
            refs.push((format!("analysis.displacement_error.sets[{k}]"), name));
        }
    }
    for (path, name) in refs {
        if body.node_set(name).is_none() {
            issues.push(DeckIssue::new(
                &path,
                format!(
                    "unknown node set {name:?}; defined sets (deck and mesh): all{}",
                    body.node_sets
                        .keys()
                        .map(|n| format!(", {n}"))
                        .collect::<String>()
                ),
            ));
        }
    }
}

/// Each node set `[analysis.displacement_error]` compares needs nodes on the solution's
/// domain (the bar between its ends).
fn exact_solution_covers_sets<const D: usize>(
    deck: &Deck,
    body: &Body<D>,
    issues: &mut Vec<DeckIssue>,
) {
    let Some(e) = deck
        .analysis
        .as_ref()
        .and_then(|a| a.displacement_error.as_ref())
    else {
        return;
    };
    let bar = e.solution.bar(0.0);
    for (k, name) in e.sets.iter().enumerate() {
        let Some(nodes) = body.node_set(name) else {
            continue; // unknown_sets says so
        };
        if !nodes
            .iter()
            .any(|&i| bar.contains(body.positions[i as usize][0]))
        {
            issues.push(DeckIssue::new(
                &format!("analysis.displacement_error.sets[{k}]"),
                format!(
                    "node set {name:?} has no node on the bar (x from {} to {} m); check the solution's fixed_end and length",
                    bar.fixed_end,
                    bar.fixed_end + bar.length
                ),
            ));
        }
    }
}

/// A 3D run's maps need nodes on the plane `[output] map_slice` names.
fn map_slice_cuts_body<const D: usize>(deck: &Deck, body: &Body<D>, issues: &mut Vec<DeckIssue>) {
    let o = &deck.output;
    let Some(slice) = o
        .map_slice
        .filter(|_| D == 3 && o.png && !o.maps.is_empty())
    else {
        return;
    };
    let axis = slice.axis.index();
    if !MapNodes::slice(&body.positions, &body.cell_sizes, axis, slice.at).is_empty() {
        return;
    }
    let [lo, hi] = extent(&body.positions, axis);
    let name = ["x", "y", "z"][axis];
    issues.push(DeckIssue::new(
        if slice.at.is_some() {
            "output.map_slice.at"
        } else {
            "output.map_slice"
        },
        format!("the map plane cuts no node; expected {name} between the nodes' {lo} and {hi} m"),
    ));
}

/// History words per bond of a damage law with one w_c for every node, for a material whose
/// pair force is `force` (for the memory estimate).
fn damage_history_words(d: &DamageDeck, force: BondForce) -> usize {
    match d {
        DamageDeck::CriticalEnergy { .. } => history_words::<UniformCriticalEnergy>(force),
        DamageDeck::Bilinear { .. } | DamageDeck::Trilinear { .. } => Softening::HISTORY,
        _ => 0,
    }
}

impl Deck {
    /// What an adaptive dynamic relaxation of the run (its own solver's or a stage's) holds
    /// per directed bond besides the run's state: copies of each bond's status byte and
    /// `history_bytes` (`memory::relaxation_bytes_per_bond`); 0 without one.
    pub fn relaxation_bytes_per_bond(&self, history_bytes: usize) -> usize {
        match self.relaxes() {
            true => memory::relaxation_bytes_per_bond(1 + history_bytes),
            false => 0,
        }
    }

    /// Whether a solver of the run (its own or a stage's) is adaptive dynamic relaxation.
    fn relaxes(&self) -> bool {
        let adr = |s: &SolverDeck| {
            matches!(
                s,
                SolverDeck::QuasiStatic {
                    method: QuasiStaticMethod::Adr,
                    ..
                }
            )
        };
        adr(&self.solver) || self.stages.iter().any(|st| adr(&st.solver))
    }

    /// The material tables of the given keys ("material", "materials.NAME").
    pub fn materials_in_use<'a>(
        &'a self,
        keys: &'a [String],
    ) -> impl Iterator<Item = &'a MaterialDeck> + 'a {
        keys.iter().map(|k| self.material_at(k))
    }

    /// The material table of a key ("material", "materials.NAME").
    pub fn material_at(&self, key: &str) -> &MaterialDeck {
        match key.strip_prefix("materials.") {
            Some(name) => &self.materials[name],
            None => &self.material,
        }
    }
}

/// Applies `[[blocks]]`: block ids by region, per-block horizons, and the material of each
/// node (index into the returned keys; 0 is `[material]` when any node uses it).
fn assign_blocks<const D: usize>(
    ld: &LoadedDeck,
    body: &mut Body<D>,
) -> Result<(Vec<u16>, Vec<String>), DeckError> {
    let deck = &ld.deck;
    let mut issues = Vec::new();
    // Per block id: the material name and horizon its entries give (all entries must agree).
    let mut settings: BTreeMap<u32, (Option<&str>, Option<f64>, usize)> = BTreeMap::new();
    for (k, b) in deck.blocks.iter().enumerate() {
        if let Some(region) = &b.region {
            body.assign_block(b.id, region);
        }
        let entry = settings.entry(b.id).or_insert((None, None, k));
        if let Some(name) = &b.material {
            match entry.0 {
                Some(other) if other != name => issues.push(DeckIssue::new(
                    &format!("blocks[{k}].material"),
                    format!("block {} is given material {name:?} here and {other:?} in blocks[{}]; one block has one material", b.id, entry.2),
                )),
                _ => entry.0 = Some(name),
            }
        }
        if let Some(h) = b.horizon {
            match entry.1 {
                Some(other) if other != h => issues.push(DeckIssue::new(
                    &format!("blocks[{k}].horizon"),
                    format!(
                        "block {} is given horizon {h} m here and {other} m in blocks[{}]",
                        b.id, entry.2
                    ),
                )),
                _ => entry.1 = Some(h),
            }
        }
    }
    for (&id, &(_, h, k)) in &settings {
        if let Some(h) = h {
            let mut any = false;
            for i in 0..body.len() {
                if body.blocks[i] == id {
                    any = true;
                    if h < body.cell_sizes[i] {
                        issues.push(DeckIssue::new(&format!("blocks[{k}].horizon"), format!("horizon {h} m of block {id} is smaller than its cells ({} m); expected δ/Δx ≥ 1, typically 3 to 4", body.cell_sizes[i])));
                        break;
                    }
                    body.horizons[i] = h;
                }
            }
            if !any {
                issues.push(DeckIssue::new(
                    &format!("blocks[{k}]"),
                    format!("block {id} has no nodes; check its region against the body"),
                ));
            }
        }
    }
    if !issues.is_empty() {
        return Err(ld.locate(issues));
    }
    let key_of = |block: u32| match settings.get(&block).and_then(|s| s.0) {
        Some(name) => format!("materials.{name}"),
        None => "material".to_string(),
    };
    let mut keys: Vec<String> = Vec::new();
    let material_of = body
        .blocks
        .iter()
        .map(|&b| {
            let key = key_of(b);
            match keys.iter().position(|k| *k == key) {
                Some(p) => p as u16,
                None => {
                    keys.push(key);
                    (keys.len() - 1) as u16
                }
            }
        })
        .collect();
    Ok((material_of, keys))
}

/// The damage-law parameters of one material at one horizon.
#[derive(Debug, Clone, Copy)]
enum LawAt {
    CriticalStretch(f64),
    CriticalEnergy(f64),
    Softening(SofteningParameters),
}

/// A material calibrated at one horizon.
struct Calibrated {
    material: BlockMaterial,
    law: LawAt,
    report: MaterialReport,
}

/// Calibrates the material table `spec` (at deck key `key`) for a horizon δ. A PMB
/// `micromodulus` is that of `reference_horizon` (the horizon the material is reported at):
/// another horizon gets the micromodulus of the same Young's modulus.
fn calibrate(
    version: u32,
    spec: &MaterialDeck,
    key: &str,
    dim: Dimensionality,
    thickness: f64,
    horizon: f64,
    reference_horizon: f64,
) -> Result<Calibrated, DeckIssue> {
    let porosity = spec.porosity().map(|p| Porosity {
        porosity: p.porosity,
        critical: p.critical_porosity,
        seed: p.seed,
    });
    let solid = |m: f64| porosity.map_or(m, |p| p.solid_phase(m));
    let g0 = spec.fracture_energy().map(solid);
    let mut report = MaterialReport {
        key: key.to_string(),
        model: spec.kind().to_string(),
        density: spec.density(),
        fracture_energy: g0,
        ..Default::default()
    };
    let profile = match spec {
        MaterialDeck::Pmb { profile, .. } => *profile,
        _ => Default::default(),
    };
    let (material, elasticity, pmb_c0) = match spec {
        MaterialDeck::Pmb {
            density,
            youngs_modulus,
            micromodulus,
            variable_horizon,
            ..
        } => {
            let c0 = match micromodulus {
                Some(c) if horizon == reference_horizon => solid(*c),
                Some(c) => {
                    let e = Pmb::youngs_modulus_of(solid(*c), dim, profile, reference_horizon);
                    Pmb::micromodulus(e, dim, profile, horizon)
                }
                None => {
                    Pmb::micromodulus(solid(youngs_modulus.unwrap_or(0.0)), dim, profile, horizon)
                }
            };
            let mut m = Pmb::new(c0, *density, dim, profile, horizon, thickness);
            m.coupling = *variable_horizon;
            if m.coupling == HorizonCoupling::Traditional {
                report.model = "pmb, traditional PD (a bond acts on its owner only)".into();
            }
            report.micromodulus = Some(c0);
            let el = m.elasticity;
            (BlockMaterial::Pmb(m), el, Some(c0))
        }
        MaterialDeck::Lps {
            density,
            youngs_modulus,
            poisson_ratio,
            influence,
            ..
        } => {
            let el = Elasticity {
                youngs_modulus: solid(*youngs_modulus),
                poisson_ratio: *poisson_ratio,
                dimensionality: dim,
            };
            let m = Lps::new(el, *influence, horizon, *density, thickness);
            (BlockMaterial::Lps(m), el, None)
        }
        MaterialDeck::Correspondence {
            density,
            youngs_modulus,
            poisson_ratio,
            influence,
            zero_energy_control,
            ..
        } => {
            let el = Elasticity {
                youngs_modulus: solid(*youngs_modulus),
                poisson_ratio: *poisson_ratio,
                dimensionality: dim,
            };
            let control = match zero_energy_control {
                ZeroEnergyDeck::Wan { coefficient } => ZeroEnergyControl::Wan {
                    coefficient: *coefficient,
                },
                ZeroEnergyDeck::Silling { coefficient } => ZeroEnergyControl::Silling {
                    coefficient: *coefficient,
                },
                ZeroEnergyDeck::None {} => ZeroEnergyControl::None,
            };
            let m = Correspondence::new(el, *influence, control, horizon, *density, thickness);
            (BlockMaterial::Correspondence(m), el, None)
        }
    };
    report.youngs_modulus = elasticity.youngs_modulus;
    report.poisson_ratio = elasticity.poisson_ratio;
    // The critical stretch a fracture energy gives this model (bond-based: exact, seed 001
    // Eq. 8; state-based: the bulk-equivalent approximation).
    let s0_from = |g: f64| match (&material, pmb_c0) {
        (_, Some(c)) => Pmb::critical_stretch_from_g0(g, c, dim, profile, horizon),
        (BlockMaterial::Lps(m), _) if version >= 2 => m.critical_stretch_from_g0(g),
        (BlockMaterial::Lps(m), _) => m.bulk_equivalent_critical_stretch(g),
        // Refused by validation: no G0 calibration of the critical stretch.
        _ => f64::INFINITY,
    };
    let path = format!("{key}.damage");
    let damage = spec.damage();
    let law = match &damage {
        DamageDeck::CriticalStretch {} => LawAt::CriticalStretch(
            spec.critical_stretch()
                .or(g0.map(s0_from))
                .unwrap_or(f64::INFINITY),
        ),
        DamageDeck::None {} => LawAt::CriticalStretch(f64::INFINITY),
        DamageDeck::CriticalEnergy {
            critical_energy, ..
        } => LawAt::CriticalEnergy(match (critical_energy, g0) {
            (Some(w), _) => *w,
            (None, Some(g)) => CriticalEnergy::critical_energy(g, horizon, dim, thickness),
            (None, None) => f64::INFINITY,
        }),
        DamageDeck::Bilinear {
            tensile_strength,
            peak_stretch,
            breaking_stretch,
        }
        | DamageDeck::Trilinear {
            tensile_strength,
            peak_stretch,
            breaking_stretch,
            ..
        } => {
            let c0 = pmb_c0.expect("validated: softening is bond-based");
            let s1 = match (tensile_strength, peak_stretch) {
                (_, Some(s1)) => *s1,
                (Some(su), None) => SofteningParameters::peak_stretch(
                    solid(*su),
                    c0,
                    profile.moment(2, horizon),
                    profile.moment(3, horizon),
                    dim,
                ),
                (None, None) => unreachable!("validated"),
            };
            let bilinear = match (breaking_stretch, g0) {
                (Some(sc), _) => SofteningParameters::bilinear(s1, *sc),
                (None, Some(g)) => {
                    SofteningParameters::bilinear_from_strength(s1, s0_from(g), horizon, dim)
                }
                (None, None) => unreachable!("validated"),
            }
            .map_err(|e| DeckIssue::new(&path, e.to_string()))?;
            let p = match damage {
                DamageDeck::Trilinear { beta, gamma, .. } => {
                    SofteningParameters::trilinear(bilinear, beta, gamma)
                        .map_err(|e| DeckIssue::new(&path, e.to_string()))?
                }
                _ => bilinear,
            };
            LawAt::Softening(p)
        }
    };
    report.damage = match (&damage, &law) {
        (_, LawAt::CriticalStretch(s)) if s.is_infinite() => "none".into(),
        (
            DamageDeck::CriticalEnergy {
                tension_only: true, ..
            },
            _,
        ) => "critical energy (tension only)".into(),
        (DamageDeck::CriticalEnergy { .. }, _) => "critical energy".into(),
        (DamageDeck::Bilinear { .. }, _) => "bilinear softening".into(),
        (DamageDeck::Trilinear { .. }, _) => "trilinear softening".into(),
        _ => "critical stretch".into(),
    };
    match law {
        LawAt::CriticalStretch(s) if s.is_finite() => {
            report.critical_stretch = Some(s);
            if let (BlockMaterial::Lps(m), Some(g), None, DamageDeck::CriticalStretch {}) =
                (&material, g0, spec.critical_stretch(), &damage)
            {
                if version < 2 {
                    report.note = Some(format!(
                        "version-1 deck: s0 is the bond-based equivalent (approximate); with version = 2 it is calibrated to G0 exactly, s0 = {:.5e}",
                        m.critical_stretch_from_g0(g)
                    ));
                }
            }
        }
        LawAt::CriticalEnergy(w) if w.is_finite() => report.critical_energy = Some(w),
        LawAt::Softening(p) => {
            report.peak_stretch = Some(p.s1);
            report.breaking_stretch = Some(p.sc);
            if matches!(damage, DamageDeck::Trilinear { .. }) {
                report.kink_stretch = Some(p.s2);
            }
        }
        _ => {}
    }
    Ok(Calibrated {
        material,
        law,
        report,
    })
}

/// Distinct horizons of a body and, per node, the index of its own.
fn horizon_classes<const D: usize>(body: &Body<D>) -> (Vec<f64>, Vec<usize>) {
    let mut distinct: Vec<f64> = Vec::new();
    let class = body
        .horizons
        .iter()
        .map(|&h| match distinct.iter().position(|&d| d == h) {
            Some(k) => k,
            None => {
                distinct.push(h);
                distinct.len() - 1
            }
        })
        .collect();
    (distinct, class)
}

/// Calibrates every material of a built model, for every horizon its nodes have.
pub fn build_constitution<const D: usize>(
    ld: &LoadedDeck,
    model: &Model<D>,
) -> Result<Constitution, DeckError> {
    build_constitution_shared(ld, model, None)
}

/// [`build_constitution`] of a rank's share of a distributed run (`share`; `None` in one
/// process): the iterated surface correction's sweeps read the ghosts' factors from their
/// owners.
pub fn build_constitution_shared<const D: usize>(
    ld: &LoadedDeck,
    model: &Model<D>,
    share: Option<&Share>,
) -> Result<Constitution, DeckError> {
    let deck = &ld.deck;
    let dim = dimensionality(deck).expect("validated deck");
    let thickness = deck.thickness.unwrap_or(1.0);
    let body = &model.body;
    let (distinct, class) = horizon_classes(body);
    let mut materials = Vec::new();
    let mut laws = Vec::new();
    let mut reports = Vec::new();
    let mut porosity = Vec::new();
    let mut issues = Vec::new();
    for (k, key) in model.materials.iter().enumerate() {
        let spec = deck.material_at(key);
        let nodes: Vec<usize> = (0..body.len())
            .filter(|&i| model.material_of[i] as usize == k)
            .collect();
        // Calibrate at each horizon this material's nodes have. The report's is the
        // discretization's horizon when some of them have it, else the smallest of theirs (not
        // the horizon of whichever node comes first: a deck's `micromodulus` is given at it).
        let mut used: Vec<usize> = nodes.iter().map(|&i| class[i]).collect();
        if used.is_empty() {
            // A rank of a distributed run whose nodes are all of other materials (one
            // horizon there: the one class).
            used = (0..distinct.len()).collect();
        }
        used.sort_unstable();
        used.dedup();
        let reference = used
            .iter()
            .copied()
            .find(|&c| distinct[c] == model.horizon)
            .or_else(|| {
                used.iter()
                    .copied()
                    .min_by(|&a, &b| distinct[a].total_cmp(&distinct[b]))
            })
            .expect("a material in use has nodes");
        let mut at: Vec<Option<Calibrated>> = (0..distinct.len()).map(|_| None).collect();
        for &c in &used {
            match calibrate(
                deck.version,
                spec,
                key,
                dim,
                thickness,
                distinct[c],
                distinct[reference],
            ) {
                Ok(cal) => at[c] = Some(cal),
                Err(issue) => issues.push(issue),
            }
        }
        if !issues.is_empty() {
            continue;
        }
        let first = at[reference].as_ref().expect("calibrated");
        let mut report = first.report.clone();
        report.nodes = nodes.len();
        let hs: Vec<f64> = used.iter().map(|&c| distinct[c]).collect();
        report.horizon_min = hs.iter().cloned().fold(f64::INFINITY, f64::min);
        report.horizon_max = hs.iter().cloned().fold(0.0, f64::max);
        reports.push(report);
        // Per-node parameters: each node takes the calibration at its own horizon (nodes of
        // other materials take the first, unused).
        let value = |f: &dyn Fn(&LawAt) -> f64| {
            PerNode::from_values(
                class
                    .iter()
                    .map(|&c| f(&at[c].as_ref().unwrap_or(first).law))
                    .collect(),
            )
        };
        let law = match first.law {
            LawAt::CriticalStretch(_) => BlockLaw::CriticalStretch(CriticalStretch {
                s0: value(&|l| match l {
                    LawAt::CriticalStretch(s) => *s,
                    _ => unreachable!(),
                }),
            }),
            LawAt::CriticalEnergy(_) => BlockLaw::CriticalEnergy(CriticalEnergy {
                wc: value(&|l| match l {
                    LawAt::CriticalEnergy(w) => *w,
                    _ => unreachable!(),
                }),
                tension_only: matches!(
                    spec.damage(),
                    DamageDeck::CriticalEnergy {
                        tension_only: true,
                        ..
                    }
                ),
            }),
            LawAt::Softening(_) => {
                let soft = |f: fn(&SofteningParameters) -> f64| {
                    value(&|l| match l {
                        LawAt::Softening(p) => f(p),
                        _ => unreachable!(),
                    })
                };
                BlockLaw::Softening(Softening {
                    shape: match spec.damage() {
                        DamageDeck::Trilinear { beta, .. } => SofteningShape::Trilinear { beta },
                        _ => SofteningShape::Bilinear,
                    },
                    s1: soft(|p| p.s1),
                    s2: soft(|p| p.s2),
                    sc: soft(|p| p.sc),
                })
            }
        };
        laws.push(law);
        let material = match &first.material {
            BlockMaterial::Pmb(m) => BlockMaterial::Pmb(m.clone().with_horizons(&body.horizons)),
            BlockMaterial::Lps(m) => BlockMaterial::Lps(m.clone().with_horizons(&body.horizons)),
            BlockMaterial::Correspondence(m) => {
                BlockMaterial::Correspondence(m.clone().with_horizons(&body.horizons))
            }
        };
        materials.push(material);
        if let Some(p) = spec.porosity() {
            porosity.push((
                k as u16,
                Porosity {
                    porosity: p.porosity,
                    critical: p.critical_porosity,
                    seed: p.seed,
                },
            ));
        }
    }
    if !issues.is_empty() {
        return Err(ld.locate(issues));
    }
    let (material, damage) = if materials.len() == 1 {
        let material = match materials.pop().expect("one material") {
            BlockMaterial::Pmb(m) => MaterialChoice::Pmb(m),
            BlockMaterial::Lps(m) => MaterialChoice::Lps(m),
            BlockMaterial::Correspondence(m) => MaterialChoice::Correspondence(m),
        };
        let damage = match laws.pop().expect("one law") {
            BlockLaw::CriticalStretch(l) => Damage::CriticalStretch(l),
            BlockLaw::CriticalEnergy(l) => Damage::CriticalEnergy(l),
            BlockLaw::Softening(l) => Damage::Softening(l),
        };
        (material, damage)
    } else {
        (
            MaterialChoice::Mixed(Mixed {
                materials,
                material_of: model.material_of.clone(),
            }),
            Damage::Mixed(MixedDamage {
                laws,
                law_of: model.material_of.clone(),
            }),
        )
    };
    let (material, surface) = surface_corrected(ld, model, material, share)?;
    Ok(Constitution {
        material,
        damage,
        reports,
        porosity,
        surface,
    })
}

/// Applies the deck's surface correction (PMB only: LPS and correspondence normalise by the
/// family they have, through m and K).
fn surface_corrected<const D: usize>(
    ld: &LoadedDeck,
    model: &Model<D>,
    material: MaterialChoice,
    share: Option<&Share>,
) -> Result<(MaterialChoice, Option<SurfaceFactors>), DeckError> {
    const KEY: &str = "discretization.surface_correction";
    let method = ld.deck.discretization.surface_correction();
    if method == SurfaceCorrection::None {
        return Ok((material, None));
    }
    let MaterialChoice::Pmb(pmb) = material else {
        return Err(ld.locate(vec![DeckIssue::new(
            KEY,
            "a surface correction applies to a body of one bond-based PMB material; LPS and \
             correspondence already normalise by the family a node has (m, K)",
        )]));
    };
    let quad = Quadrature::for_body(model.rule, &model.body, &model.bonds);
    let factors = surface_factors(method, &model.body, &model.bonds, &quad, &pmb, share)
        .map_err(|e| ld.locate(vec![DeckIssue::new(KEY, e.to_string())]))?
        .expect("a method was asked for");
    let pmb = corrected(pmb, &factors.factors);
    Ok((MaterialChoice::Pmb(pmb), Some(factors)))
}
