//! Physics and consistency checks on a parsed deck. Each issue carries the key path and says
//! what was found and what is expected.

use super::schema::*;
use super::DeckIssue;
use crate::loading::Kinematic;
use crate::material::pmb::{bond_based_poisson_ratio, HorizonCoupling};
use crate::material::Dimensionality;

/// The dimensionality a deck asks for, if its settings are consistent.
pub fn dimensionality(deck: &Deck) -> Option<Dimensionality> {
    match (deck.dimension, deck.plane) {
        (3, _) => Some(Dimensionality::ThreeD),
        (2, Some(Plane::Stress)) => Some(Dimensionality::PlaneStress),
        (2, Some(Plane::Strain)) => Some(Dimensionality::PlaneStrain),
        _ => None,
    }
}

fn positive(issues: &mut Vec<DeckIssue>, path: &str, value: f64, what: &str) {
    if !(value.is_finite() && value > 0.0) {
        issues.push(DeckIssue::new(
            path,
            format!("{what} must be a positive finite number, found {value}"),
        ));
    }
}

/// `horizon` or `horizon_ratio` (of `spacing`), exactly one, each at least the spacing.
fn check_horizon(
    out: &mut Vec<DeckIssue>,
    horizon: Option<f64>,
    horizon_ratio: Option<f64>,
    spacing: f64,
) {
    match (horizon, horizon_ratio) {
        (Some(_), Some(_)) => out.push(DeckIssue::new(
            "discretization.horizon_ratio",
            "give `horizon` or `horizon_ratio`, not both",
        )),
        (None, None) => out.push(DeckIssue::new(
            "discretization",
            "missing the horizon: give `horizon` (m) or `horizon_ratio` (δ/Δx)",
        )),
        (Some(h), None) => {
            positive(out, "discretization.horizon", h, "horizon (m)");
            if h > 0.0 && spacing > 0.0 && h < spacing {
                out.push(DeckIssue::new("discretization.horizon", format!("horizon {h} m is smaller than the spacing {spacing} m (δ/Δx = {:.3}); peridynamics needs δ/Δx ≥ 1, typically 3 to 4", h / spacing)));
            }
        }
        (None, Some(r)) => {
            positive(out, "discretization.horizon_ratio", r, "horizon ratio δ/Δx");
            if r.is_finite() && r > 0.0 && r < 1.0 {
                out.push(DeckIssue::new("discretization.horizon_ratio", format!("δ/Δx = {r} makes the horizon smaller than the spacing; expected at least 1, typically 3 to 4")));
            }
        }
    }
}

/// Random pores: a count, radii 0 < r_min ≤ r_max, a clearance ≥ 0.
fn check_pores(out: &mut Vec<DeckIssue>, pores: &Option<PoresDeck>) {
    let Some(p) = pores else { return };
    if p.count == 0 {
        out.push(DeckIssue::new(
            "discretization.pores.count",
            "expected at least one pore (remove `pores` for none)",
        ));
    }
    let [lo, hi] = p.radius;
    if !(lo.is_finite() && hi.is_finite() && 0.0 < lo && lo <= hi) {
        out.push(DeckIssue::new(
            "discretization.pores.radius",
            format!("expected [r_min, r_max] with 0 < r_min ≤ r_max (m), found [{lo}, {hi}]"),
        ));
    }
    if !(p.clearance.is_finite() && p.clearance >= 0.0) {
        out.push(DeckIssue::new(
            "discretization.pores.clearance",
            format!("expected a gap ≥ 0 (m), found {}", p.clearance),
        ));
    }
}

/// All problems found; empty if the deck is usable.
pub fn validate(deck: &Deck) -> Vec<DeckIssue> {
    let mut out = Vec::new();
    let d = deck.dimension;
    if !(1..=LATEST_VERSION).contains(&deck.version) {
        out.push(DeckIssue::new(
            "version",
            format!(
                "unsupported deck version {}; this peridyn reads versions 1 to {LATEST_VERSION}",
                deck.version
            ),
        ));
    }
    if d != 2 && d != 3 {
        out.push(DeckIssue::new(
            "dimension",
            format!("dimension must be 2 or 3, found {d}"),
        ));
        return out;
    }
    if d == 2 {
        if deck.plane.is_none() {
            out.push(DeckIssue::new(
                "dimension",
                "a 2D deck needs `plane = \"stress\"` or `plane = \"strain\"`",
            ));
        }
        match deck.thickness {
            None => out.push(DeckIssue::new(
                "dimension",
                "a 2D deck needs `thickness` (m), the out-of-plane thickness",
            )),
            Some(t) => positive(&mut out, "thickness", t, "thickness (m)"),
        }
    } else {
        if deck.plane.is_some() {
            out.push(DeckIssue::new(
                "plane",
                "`plane` applies to 2D decks only; remove it for dimension = 3",
            ));
        }
        if deck.thickness.is_some() {
            out.push(DeckIssue::new(
                "thickness",
                "`thickness` applies to 2D decks only; remove it for dimension = 3",
            ));
        }
    }
    let dimensionality = dimensionality(deck);

    let check_shape = |out: &mut Vec<DeckIssue>, path: &str, shape: &crate::geometry::Shape| {
        if let Err(e) = shape.validate() {
            out.push(DeckIssue::new(path, e.to_string()));
        } else if let Ok(sd) = shape.dim() {
            if sd != d {
                out.push(DeckIssue::new(
                    path,
                    format!(
                        "a {sd}D shape ({}) in a {d}D deck; expected a {d}D shape",
                        shape.kind()
                    ),
                ));
            }
        }
    };

    match &deck.discretization {
        Discretization::Lattice {
            shape,
            spacing,
            horizon,
            horizon_ratio,
            refine,
            pores,
            ..
        } => {
            check_shape(&mut out, "discretization.shape", shape);
            positive(
                &mut out,
                "discretization.spacing",
                *spacing,
                "lattice spacing (m)",
            );
            check_horizon(&mut out, *horizon, *horizon_ratio, *spacing);
            for (k, r) in refine.iter().enumerate() {
                let p = format!("discretization.refine[{k}]");
                check_shape(&mut out, &format!("{p}.region"), &r.region);
                let max = crate::discretize::multigrid::MAX_LEVEL;
                if r.levels == 0 || r.levels > max {
                    out.push(DeckIssue::new(
                        &format!("{p}.levels"),
                        format!(
                            "expected 1 to {max} levels of refinement, found {}",
                            r.levels
                        ),
                    ));
                }
            }
            check_pores(&mut out, pores);
        }
        Discretization::FreeMesh {
            shape,
            size,
            horizon,
            horizon_ratio,
            pores,
            ..
        }
        | Discretization::Nbnug {
            shape,
            size,
            horizon,
            horizon_ratio,
            pores,
            ..
        } => {
            if d != 2 {
                out.push(DeckIssue::new(
                    "discretization.type",
                    "free meshes and NB-NUG grids are 2D; in 3D use a lattice (with `refine`) or a Gmsh mesh",
                ));
            }
            check_shape(&mut out, "discretization.shape", shape);
            positive(&mut out, "discretization.size", *size, "element size (m)");
            check_horizon(&mut out, *horizon, *horizon_ratio, *size);
            if let Discretization::Nbnug {
                padding: Some(p), ..
            } = &deck.discretization
            {
                positive(&mut out, "discretization.padding", *p, "box padding (m)");
            }
            check_pores(&mut out, pores);
        }
        Discretization::PointCloud { file, horizon, .. }
        | Discretization::Gmsh { file, horizon, .. } => {
            if file.trim().is_empty() {
                out.push(DeckIssue::new(
                    "discretization.file",
                    if matches!(deck.discretization, Discretization::Gmsh { .. }) {
                        "expected the path of a Gmsh mesh (.msh)"
                    } else {
                        "expected the path of a point-cloud file"
                    },
                ));
            }
            positive(&mut out, "discretization.horizon", *horizon, "horizon (m)");
        }
    }

    validate_material(&mut out, "material", &deck.material, dimensionality);
    for (name, m) in &deck.materials {
        validate_material(&mut out, &format!("materials.{name}"), m, dimensionality);
    }

    let mut names: Vec<&str> = Vec::new();
    for (k, set) in deck.node_sets.iter().enumerate() {
        let p = format!("node_sets[{k}]");
        if set.name.trim().is_empty() || set.name == "all" {
            out.push(DeckIssue::new(
                &format!("{p}.name"),
                format!(
                    "node set name {:?} is reserved or empty; `all` always means every node",
                    set.name
                ),
            ));
        }
        if names.contains(&set.name.as_str()) {
            out.push(DeckIssue::new(
                &format!("{p}.name"),
                format!("node set {:?} is defined twice", set.name),
            ));
        }
        names.push(&set.name);
        check_shape(&mut out, &format!("{p}.region"), &set.region);
    }
    validate_boundary_layers(&mut out, deck, &mut names);
    // A mesh's named physical groups are node sets too; they are known once it is read.
    let from_mesh = matches!(deck.discretization, Discretization::Gmsh { .. });
    let known = |name: &str| from_mesh || name == "all" || names.contains(&name);
    let unknown_set = |name: &str| {
        format!(
            "unknown node set {name:?}; defined sets: all{}",
            names.iter().map(|n| format!(", {n}")).collect::<String>()
        )
    };

    for (k, b) in deck.blocks.iter().enumerate() {
        if let Some(region) = &b.region {
            check_shape(&mut out, &format!("blocks[{k}].region"), region);
        } else if !matches!(
            deck.discretization,
            Discretization::PointCloud { .. } | Discretization::Gmsh { .. }
        ) {
            out.push(DeckIssue::new(
                &format!("blocks[{k}]"),
                "a block needs a `region` (only a point cloud or a Gmsh mesh can give block ids without one)",
            ));
        }
        if let Some(name) = &b.material {
            if !deck.materials.contains_key(name) {
                out.push(DeckIssue::new(
                    &format!("blocks[{k}].material"),
                    format!(
                        "unknown material {name:?}; define it as [materials.{name}] (defined: {})",
                        if deck.materials.is_empty() {
                            "none".to_string()
                        } else {
                            deck.materials
                                .keys()
                                .cloned()
                                .collect::<Vec<_>>()
                                .join(", ")
                        }
                    ),
                ));
            }
        }
        if let Some(h) = b.horizon {
            positive(&mut out, &format!("blocks[{k}].horizon"), h, "horizon (m)");
        }
    }
    for (k, c) in deck.precracks.iter().enumerate() {
        let p = format!("precracks[{k}]");
        if c.dim() != d {
            out.push(DeckIssue::new(
                &p,
                format!(
                    "a {}D pre-crack in a {d}D deck; use type = \"{}\"",
                    c.dim(),
                    if d == 2 { "segment" } else { "rectangle" }
                ),
            ));
        } else if let Err(e) = c.validate() {
            out.push(DeckIssue::new(&p, e));
        }
    }
    validate_loading(
        &mut out,
        "",
        (&deck.no_fail, &deck.boundary_conditions, &deck.loads),
        &known,
        &unknown_set,
        d,
    );
    for (k, iv) in deck.initial_velocities.iter().enumerate() {
        let p = format!("initial_velocities[{k}]");
        if !known(&iv.set) {
            out.push(DeckIssue::new(&format!("{p}.set"), unknown_set(&iv.set)));
        }
        vector(&mut out, &format!("{p}.value"), &iv.value, d);
        if let Some(g) = &iv.gradient {
            if g.len() != d {
                out.push(DeckIssue::new(
                    &format!("{p}.gradient"),
                    format!(
                        "expected a {d}×{d} matrix (∂v_a/∂x_b, {d} rows), found {} rows",
                        g.len()
                    ),
                ));
            }
            for (r, row) in g.iter().enumerate() {
                vector(&mut out, &format!("{p}.gradient[{r}]"), row, d);
            }
        }
        if let Some(o) = &iv.origin {
            vector(&mut out, &format!("{p}.origin"), o, d);
        }
    }

    super::contact::validate(&mut out, deck);
    validate_maps(&mut out, &deck.output, d);
    if deck.output.checkpoint_interval == Some(0) {
        out.push(DeckIssue::new(
            "output.checkpoint_interval",
            "expected a number of steps ≥ 1 between checkpoints, found 0 (remove the key to checkpoint only at snapshots)",
        ));
    }

    let mut names = std::collections::BTreeSet::new();
    for (k, o) in deck.output.openings.iter().enumerate() {
        let p = format!("output.openings[{k}]");
        column_name(&mut out, &mut names, &p, "opening", &o.name);
        for (j, point) in o.between.iter().enumerate() {
            vector(&mut out, &format!("{p}.between[{j}]"), point, d);
        }
    }
    let mut names = std::collections::BTreeSet::new();
    for (k, probe) in deck.output.probes.iter().enumerate() {
        let p = format!("output.probes[{k}]");
        column_name(&mut out, &mut names, &p, "probe", &probe.name);
        vector(&mut out, &format!("{p}.at"), &probe.at, d);
    }

    let softens = std::iter::once(&deck.material)
        .chain(deck.materials.values())
        .any(|m| {
            matches!(
                m.damage(),
                DamageDeck::Bilinear { .. } | DamageDeck::Trilinear { .. }
            )
        });
    validate_solver(
        &mut out,
        "",
        &deck.solver,
        softens,
        ("", &deck.boundary_conditions),
        !deck.initial_velocities.is_empty(),
    );
    validate_stages(&mut out, deck, softens, &known, &unknown_set);
    validate_traditional_horizons(&mut out, deck);
    if let Some(tip) = deck.analysis.as_ref().and_then(|a| a.crack_tip.as_ref()) {
        validate_crack_tip(&mut out, tip, d);
    }
    if let Some(path) = deck.analysis.as_ref().and_then(|a| a.crack_path.as_ref()) {
        validate_crack_path(&mut out, path, d);
        if let Some(region) = &path.region {
            check_shape(&mut out, "analysis.crack_path.region", region);
        }
    }
    if let Some(surface) = deck
        .analysis
        .as_ref()
        .and_then(|a| a.crack_surface.as_ref())
    {
        validate_crack_surface(&mut out, surface, d);
    }
    if let Some(c) = deck
        .analysis
        .as_ref()
        .and_then(|a| a.crack_crossings.as_ref())
    {
        validate_crack_crossings(&mut out, c, d);
    }
    if let Some(e) = deck
        .analysis
        .as_ref()
        .and_then(|a| a.displacement_error.as_ref())
    {
        validate_displacement_error(&mut out, e, &known, &unknown_set);
    }
    out
}

/// `[analysis.displacement_error]`: a solution with a positive length and wave speed and a
/// finite strain and position, known node sets each once, a schedule.
fn validate_displacement_error(
    out: &mut Vec<DeckIssue>,
    e: &DisplacementErrorDeck,
    known: &dyn Fn(&str) -> bool,
    unknown_set: &dyn Fn(&str) -> String,
) {
    let p = "analysis.displacement_error";
    let ExactSolutionDeck::FixedFreeBar {
        strain,
        length,
        fixed_end,
        release,
        wave_speed,
    } = &e.solution;
    let at = |key: &str| format!("{p}.solution.{key}");
    positive(out, &at("length"), *length, "the bar's length (m)");
    if let Some(c) = wave_speed {
        positive(out, &at("wave_speed"), *c, "the wave speed (m/s)");
    }
    for (key, value) in [
        ("strain", strain),
        ("fixed_end", fixed_end),
        ("release", release),
    ] {
        if !value.is_finite() {
            out.push(DeckIssue::new(
                &at(key),
                format!("expected a finite number, found {value}"),
            ));
        }
    }
    if e.sets.is_empty() {
        out.push(DeckIssue::new(
            &format!("{p}.sets"),
            "expected at least one node set (\"all\": every node on the bar)",
        ));
    }
    for (k, name) in e.sets.iter().enumerate() {
        if !known(name) {
            out.push(DeckIssue::new(&format!("{p}.sets[{k}]"), unknown_set(name)));
        } else if e.sets[..k].contains(name) {
            out.push(DeckIssue::new(
                &format!("{p}.sets[{k}]"),
                format!("node set {name:?} is listed twice"),
            ));
        }
    }
    if e.interval == 0 {
        out.push(DeckIssue::new(
            &format!("{p}.interval"),
            "expected at least 1 step between rows, found 0",
        ));
    }
}

/// A name that becomes part of a history column (an opening's, a probe's): letters, digits
/// and _ only, each once among its kind.
fn column_name(
    out: &mut Vec<DeckIssue>,
    names: &mut std::collections::BTreeSet<String>,
    path: &str,
    kind: &str,
    name: &str,
) {
    let article = if kind.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "an"
    } else {
        "a"
    };
    if name.is_empty() || !name.chars().all(|c| c.is_alphanumeric() || c == '_') {
        out.push(DeckIssue::new(
            &format!("{path}.name"),
            format!("{article} {kind}'s name becomes a history column: letters, digits and _ only, found {name:?}"),
        ));
    } else if !names.insert(name.to_string()) {
        out.push(DeckIssue::new(
            &format!("{path}.name"),
            format!("the {kind} {name:?} is defined twice"),
        ));
    }
}

/// `variable_horizon = "traditional"` (seed 003 §2.2) is a comparison model for waves and
/// critical-stretch fracture: its forces are not the gradient of an energy, and its bonds
/// act on one end only, so it takes one material, explicit solvers and a stretch criterion.
fn validate_traditional_horizons(out: &mut Vec<DeckIssue>, deck: &Deck) {
    let traditional = |m: &MaterialDeck| {
        matches!(
            m,
            MaterialDeck::Pmb {
                variable_horizon: HorizonCoupling::Traditional,
                ..
            }
        )
    };
    let tables = std::iter::once(("material".to_string(), &deck.material)).chain(
        deck.materials
            .iter()
            .map(|(name, m)| (format!("materials.{name}"), m)),
    );
    for (path, m) in tables.filter(|(_, m)| traditional(m)) {
        let key = format!("{path}.variable_horizon");
        if !deck.materials.is_empty() {
            out.push(DeckIssue::new(
                &key,
                "traditional variable-horizon PD takes one material (`[material]` alone): a bond between two materials has no traditional form here",
            ));
        }
        if !matches!(
            m.damage(),
            DamageDeck::None {} | DamageDeck::CriticalStretch {}
        ) {
            out.push(DeckIssue::new(
                &key,
                "traditional variable-horizon PD takes damage = { type = \"none\" } or \"critical_stretch\": the work of a bond is not defined when its two ends feel different forces",
            ));
        }
        let solvers = std::iter::once(("solver".to_string(), &deck.solver)).chain(
            deck.stages
                .iter()
                .enumerate()
                .map(|(k, st)| (format!("stages[{k}].solver"), &st.solver)),
        );
        for (at, solver) in solvers {
            if !matches!(solver, SolverDeck::Explicit { .. }) {
                out.push(DeckIssue::new(
                    &format!("{at}.type"),
                    format!("{key} = \"traditional\" runs with explicit dynamics only: its forces are not the gradient of an energy, which the quasi-static solvers need"),
                ));
            }
        }
    }
}

/// `[[boundary_layers]]`: their names join the node sets.
fn validate_boundary_layers<'a>(
    out: &mut Vec<DeckIssue>,
    deck: &'a Deck,
    names: &mut Vec<&'a str>,
) {
    let file_mesh = matches!(
        deck.discretization,
        Discretization::PointCloud { .. } | Discretization::Gmsh { .. }
    );
    let mut sides = Vec::new();
    for (k, layer) in deck.boundary_layers.iter().enumerate() {
        let p = format!("boundary_layers[{k}]");
        if layer.name.trim().is_empty() || layer.name == "all" {
            out.push(DeckIssue::new(
                &format!("{p}.name"),
                format!(
                    "layer name {:?} is reserved or empty; `all` always means every node",
                    layer.name
                ),
            ));
        } else if names.contains(&layer.name.as_str()) {
            out.push(DeckIssue::new(
                &format!("{p}.name"),
                format!("{:?} already names a node set or another layer", layer.name),
            ));
        }
        names.push(&layer.name);
        let (axis, _) = layer.side.axis_and_end();
        if axis >= deck.dimension {
            out.push(DeckIssue::new(
                &format!("{p}.side"),
                "a 2D body has no z faces; expected \"-x\", \"+x\", \"-y\" or \"+y\"",
            ));
        }
        if sides.contains(&layer.side) {
            out.push(DeckIssue::new(
                &format!("{p}.side"),
                "another layer is on this face already; one layer per face",
            ));
        }
        sides.push(layer.side);
        if let Some(w) = layer.width {
            positive(out, &format!("{p}.width"), w, "layer width (m)");
        }
        match layer.spacing {
            Some(s) => positive(out, &format!("{p}.spacing"), s, "layer node spacing (m)"),
            None if file_mesh => out.push(DeckIssue::new(
                &format!("{p}.spacing"),
                "a layer next to a mesh read from a file needs `spacing` (m), the distance of its nodes",
            )),
            None => {}
        }
    }
}

/// `[analysis.crack_surface]`: 3D, a positive cell side, a schedule.
fn validate_crack_surface(out: &mut Vec<DeckIssue>, surface: &CrackSurfaceDeck, d: usize) {
    let at = |key: &str| format!("analysis.crack_surface.{key}");
    if d != 3 {
        out.push(DeckIssue::new(
            "analysis.crack_surface",
            "the crack surface is measured in 3D decks only (a 2D crack is a line: use [analysis.crack_path]); remove the table",
        ));
        return;
    }
    if let Some(v) = surface.bin_width.filter(|v| !(*v > 0.0 && v.is_finite())) {
        out.push(DeckIssue::new(
            &at("bin_width"),
            format!("expected a cell side > 0 (m), found {v}"),
        ));
    }
    if surface.interval == 0 {
        out.push(DeckIssue::new(
            &at("interval"),
            "expected at least 1 step between area samples, found 0",
        ));
    }
}

/// A damage threshold of an analysis: in [0, 1). Damage lies in [0, 1]; "above 1" would never
/// hold, so 1 is refused too.
fn damage_threshold(out: &mut Vec<DeckIssue>, path: &str, threshold: f64) {
    if !(0.0..1.0).contains(&threshold) {
        out.push(DeckIssue::new(
            path,
            format!("the damage threshold must lie in [0, 1), found {threshold}"),
        ));
    }
}

/// `[analysis.crack_path]`: 2D, an in-plane axis, positive lengths, a reference of points.
fn validate_crack_path(out: &mut Vec<DeckIssue>, path: &CrackPathDeck, d: usize) {
    let at = |key: &str| format!("analysis.crack_path.{key}");
    if d != 2 {
        out.push(DeckIssue::new(
            "analysis.crack_path",
            "crack paths and forks are measured in 2D decks only (a 3D crack is a surface); remove the table",
        ));
        return;
    }
    if path.axis.index() > 1 {
        out.push(DeckIssue::new(
            &at("axis"),
            "expected \"x\" or \"y\" in a 2D deck, found \"z\"",
        ));
    }
    damage_threshold(out, &at("threshold"), path.threshold);
    for (key, value) in [("bin_width", path.bin_width), ("link", path.link)] {
        if let Some(v) = value.filter(|v| !(*v > 0.0 && v.is_finite())) {
            out.push(DeckIssue::new(
                &at(key),
                format!("expected a length > 0 (m), found {v}"),
            ));
        }
    }
    for (k, point) in path.reference.iter().enumerate() {
        vector(
            out,
            &format!("analysis.crack_path.reference[{k}]"),
            point,
            2,
        );
    }
    if path.reference.len() == 1 {
        out.push(DeckIssue::new(
            &at("reference"),
            "a reference path needs at least two points, found one",
        ));
    }
    if path.samples < 2 {
        out.push(DeckIssue::new(
            &at("samples"),
            format!("expected at least 2 samples, found {}", path.samples),
        ));
    }
    if path.interval == 0 {
        out.push(DeckIssue::new(
            &at("interval"),
            "expected at least 1 step between fork checks, found 0",
        ));
    }
    if path.fit_bands == 0 {
        out.push(DeckIssue::new(
            &at("fit_bands"),
            "expected at least 1 band to fit a branch over, found 0",
        ));
    }
}

/// `[analysis.crack_crossings]`: 2D, a threshold and schedule, named segments with a length
/// and positive widths.
fn validate_crack_crossings(out: &mut Vec<DeckIssue>, c: &CrackCrossingsDeck, d: usize) {
    let p = "analysis.crack_crossings";
    let at = |key: &str| format!("{p}.{key}");
    if d != 2 {
        out.push(DeckIssue::new(
            p,
            "crack crossings are counted in 2D decks only (a line does not separate the cracks of a 3D body); remove the table",
        ));
        return;
    }
    damage_threshold(out, &at("threshold"), c.threshold);
    if c.interval == 0 {
        out.push(DeckIssue::new(
            &at("interval"),
            "expected at least 1 step between counts, found 0",
        ));
    }
    if let Some(link) = c.link {
        positive(out, &at("link"), link, "the link distance (m)");
    }
    if c.lines.is_empty() {
        out.push(DeckIssue::new(
            &at("lines"),
            "expected at least one line ([[analysis.crack_crossings.lines]] with name, from, to)",
        ));
    }
    let mut names: Vec<&str> = Vec::new();
    for (k, line) in c.lines.iter().enumerate() {
        let lp = format!("{p}.lines[{k}]");
        let name = line.name.trim();
        if name.is_empty() || name.contains([',', '"']) || ["time", "step"].contains(&name) {
            out.push(DeckIssue::new(
                &format!("{lp}.name"),
                format!(
                    "expected a column name other than time and step, without commas or quotes, found {:?}",
                    line.name
                ),
            ));
        } else if names.contains(&name) {
            out.push(DeckIssue::new(
                &format!("{lp}.name"),
                format!("line {name:?} is defined twice"),
            ));
        }
        names.push(name);
        let before = out.len();
        vector(out, &format!("{lp}.from"), &line.from, d);
        vector(out, &format!("{lp}.to"), &line.to, d);
        if out.len() == before && line.from == line.to {
            out.push(DeckIssue::new(
                &format!("{lp}.to"),
                format!(
                    "the line needs two distinct ends, found {:?} twice",
                    line.from
                ),
            ));
        }
        if let Some(w) = line.width {
            positive(out, &format!("{lp}.width"), w, "the strip's width (m)");
        }
    }
}

/// `[output]` maps: each field once; a slice plane only in 3D, at a finite coordinate.
/// (Whether the plane cuts the body is checked once the body is built.)
fn validate_maps(out: &mut Vec<DeckIssue>, o: &OutputDeck, d: usize) {
    for (k, field) in o.maps.iter().enumerate() {
        if o.maps[..k].contains(field) {
            out.push(DeckIssue::new(
                &format!("output.maps[{k}]"),
                format!("the map {:?} is listed twice", field.name()),
            ));
        }
    }
    let Some(slice) = &o.map_slice else { return };
    if d != 3 {
        out.push(DeckIssue::new(
            "output.map_slice",
            "`map_slice` applies to 3D decks only (2D maps show the whole body); remove it",
        ));
    } else if let Some(at) = slice.at.filter(|a| !a.is_finite()) {
        out.push(DeckIssue::new(
            "output.map_slice.at",
            format!("the slice plane's coordinate (m) must be a finite number, found {at}"),
        ));
    }
}

/// `[analysis.crack_tip]`: a usable direction, threshold, schedule and branch boxes.
fn validate_crack_tip(out: &mut Vec<DeckIssue>, tip: &CrackTipDeck, d: usize) {
    let p = "analysis.crack_tip";
    let at = |key: &str| format!("{p}.{key}");
    let before = out.len();
    vector(out, &at("direction"), &tip.direction, d);
    if out.len() == before && tip.direction.iter().all(|x| *x == 0.0) {
        out.push(DeckIssue::new(
            &at("direction"),
            "the propagation direction must be non-zero",
        ));
    }
    damage_threshold(out, &at("threshold"), tip.threshold);
    if tip.interval == 0 {
        out.push(DeckIssue::new(
            &at("interval"),
            "expected at least 1 step between tip samples, found 0",
        ));
    }
    if tip.window == 0 {
        out.push(DeckIssue::new(
            &at("window"),
            "expected a speed window of at least 1 sample, found 0",
        ));
    }
    let mut names: Vec<&str> = Vec::new();
    for (k, b) in tip.branches.iter().enumerate() {
        let bp = format!("{p}.branches[{k}]");
        if b.name.trim().is_empty() {
            out.push(DeckIssue::new(
                &format!("{bp}.name"),
                "expected a branch name (it prefixes the branch's columns)",
            ));
        } else if names.contains(&b.name.as_str()) {
            out.push(DeckIssue::new(
                &format!("{bp}.name"),
                format!("branch {:?} is defined twice", b.name),
            ));
        }
        names.push(&b.name);
        let before = out.len();
        vector(out, &format!("{bp}.min"), &b.min, d);
        vector(out, &format!("{bp}.max"), &b.max, d);
        if out.len() == before && b.min.iter().zip(&b.max).any(|(lo, hi)| lo >= hi) {
            out.push(DeckIssue::new(
                &format!("{bp}.max"),
                format!(
                    "the search box needs min < max in every component, found min {:?}, max {:?}",
                    b.min, b.max
                ),
            ));
        }
    }
}

/// Checks one material table (`[material]` or `[materials.NAME]`, at `path`).
fn validate_material(
    out: &mut Vec<DeckIssue>,
    path: &str,
    m: &MaterialDeck,
    dimensionality: Option<Dimensionality>,
) {
    let at = |key: &str| format!("{path}.{key}");
    positive(out, &at("density"), m.density(), "density (kg/m³)");
    match m {
        MaterialDeck::Pmb {
            youngs_modulus,
            micromodulus,
            poisson_ratio,
            ..
        } => {
            match (youngs_modulus, micromodulus) {
                (Some(_), Some(_)) => out.push(DeckIssue::new(
                    &at("micromodulus"),
                    "give `youngs_modulus` or `micromodulus`, not both",
                )),
                (None, None) => out.push(DeckIssue::new(
                    path,
                    "missing stiffness: give `youngs_modulus` (Pa) or `micromodulus`",
                )),
                (Some(e), None) => positive(out, &at("youngs_modulus"), *e, "Young's modulus (Pa)"),
                (None, Some(c)) => positive(out, &at("micromodulus"), *c, "micromodulus"),
            }
            if let (Some(nu), Some(dm)) = (poisson_ratio, dimensionality) {
                let fixed = bond_based_poisson_ratio(dm);
                if (nu - fixed).abs() > 1e-6 {
                    out.push(DeckIssue::new(
                        &at("poisson_ratio"),
                        format!("bond-based PMB fixes Poisson's ratio at {fixed:.4} in {}; found {nu}. Use type = \"lps\" or \"correspondence\" for another Poisson ratio", dm.describe()),
                    ));
                }
            }
        }
        MaterialDeck::Lps {
            youngs_modulus,
            poisson_ratio,
            ..
        }
        | MaterialDeck::Correspondence {
            youngs_modulus,
            poisson_ratio,
            ..
        } => {
            positive(
                out,
                &at("youngs_modulus"),
                *youngs_modulus,
                "Young's modulus (Pa)",
            );
            if !(poisson_ratio.is_finite() && *poisson_ratio > -1.0 && *poisson_ratio < 0.5) {
                out.push(DeckIssue::new(&at("poisson_ratio"), format!("Poisson's ratio must lie in (-1, 0.5) for a stable isotropic solid, found {poisson_ratio}")));
            }
        }
    }
    if let MaterialDeck::Correspondence {
        zero_energy_control:
            ZeroEnergyDeck::Wan { coefficient } | ZeroEnergyDeck::Silling { coefficient },
        ..
    } = m
    {
        positive(
            out,
            &at("zero_energy_control.coefficient"),
            *coefficient,
            "zero-energy control coefficient",
        );
    }
    let (g0, s0) = (m.fracture_energy(), m.critical_stretch());
    if let Some(g) = g0 {
        positive(out, &at("fracture_energy"), g, "fracture energy G0 (J/m²)");
    }
    if let Some(s) = s0 {
        positive(out, &at("critical_stretch"), s, "critical stretch");
    }
    let damage = m.damage();
    if s0.is_some() && damage != (DamageDeck::CriticalStretch {}) {
        out.push(DeckIssue::new(
            &at("critical_stretch"),
            "`critical_stretch` belongs to the critical-stretch law; remove it or the `damage` table",
        ));
    }
    let dpath = at("damage");
    let dat = |key: &str| format!("{dpath}.{key}");
    match &damage {
        DamageDeck::CriticalStretch {} => {
            if g0.is_some() && s0.is_some() {
                out.push(DeckIssue::new(
                    &at("critical_stretch"),
                    "give `fracture_energy` or `critical_stretch`, not both",
                ));
            }
            if g0.is_some() && matches!(m, MaterialDeck::Correspondence { .. }) {
                out.push(DeckIssue::new(
                    &at("fracture_energy"),
                    "the critical stretch of the correspondence model has no calibration from G0; use `damage = { type = \"critical_energy\" }` (seed 004), or give `critical_stretch` instead",
                ));
            }
        }
        DamageDeck::None {} => {}
        DamageDeck::CriticalEnergy {
            critical_energy, ..
        } => match (critical_energy, g0) {
            (Some(w), _) => positive(out, &dat("critical_energy"), *w, "critical bond energy (J/m⁶)"),
            (None, None) => out.push(DeckIssue::new(
                &dpath,
                format!("the critical-energy law needs `{path}.fracture_energy` (G0, J/m²) or `critical_energy` (w_c, J/m⁶)"),
            )),
            _ => {}
        },
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
            if !matches!(m, MaterialDeck::Pmb { .. }) {
                out.push(DeckIssue::new(
                    &dpath,
                    format!("softening bond laws are calibrated for bond-based PD (seed 001 §4); use them with type = \"pmb\", not \"{}\"", m.kind()),
                ));
            }
            match (tensile_strength, peak_stretch) {
                (Some(_), Some(_)) => out.push(DeckIssue::new(&dat("peak_stretch"), "give `tensile_strength` or `peak_stretch`, not both")),
                (None, None) => out.push(DeckIssue::new(&dpath, "a softening law needs `tensile_strength` (σu, Pa) or `peak_stretch` (s1)")),
                (Some(v), None) => positive(out, &dat("tensile_strength"), *v, "tensile strength (Pa)"),
                (None, Some(v)) => positive(out, &dat("peak_stretch"), *v, "peak stretch"),
            }
            match (breaking_stretch, g0) {
                (Some(v), _) => positive(out, &dat("breaking_stretch"), *v, "breaking stretch"),
                (None, None) => out.push(DeckIssue::new(&dpath, format!("a softening law needs `{path}.fracture_energy` (G0, J/m²) or `breaking_stretch` (sc)"))),
                _ => {}
            }
            if let DamageDeck::Trilinear { beta, gamma, .. } = damage {
                if !(beta > 0.0 && beta < 1.0) {
                    out.push(DeckIssue::new(&dat("beta"), format!("β must lie in (0, 1), found {beta}")));
                }
                if !(gamma > 1.0 && gamma.is_finite()) {
                    out.push(DeckIssue::new(&dat("gamma"), format!("γ must be greater than 1, found {gamma}")));
                }
            }
        }
    }
    if let Some(p) = m.porosity() {
        let pp = at("porosity");
        if !(p.porosity >= 0.0 && p.porosity < 1.0) {
            out.push(DeckIssue::new(
                &format!("{pp}.porosity"),
                format!("porosity must lie in [0, 1), found {}", p.porosity),
            ));
        }
        if !(p.critical_porosity > p.porosity && p.critical_porosity <= 1.0) {
            out.push(DeckIssue::new(
                &format!("{pp}.critical_porosity"),
                format!(
                    "critical porosity φc must lie in (φ, 1], found {}",
                    p.critical_porosity
                ),
            ));
        }
    }
}

/// A `[solver]` table at `prefix` ("" or "stages[k]."), with the boundary conditions it runs
/// under and where they are written (`at`: a stage may keep those of a stage before it).
fn validate_solver(
    issues: &mut Vec<DeckIssue>,
    prefix: &str,
    solver: &SolverDeck,
    softens: bool,
    (at, conditions): (&str, &[BoundaryDeck]),
    initial_velocities: bool,
) {
    match solver {
        SolverDeck::Explicit {
            steps,
            end_time,
            dt,
            safety_factor,
            damping,
            adaptive,
        } => {
            if let Some(a) = adaptive {
                validate_adaptive(issues, prefix, a);
            }
            match (steps, end_time) {
                (Some(_), Some(_)) => issues.push(DeckIssue::new(
                    &format!("{prefix}solver.end_time"),
                    "give `steps` or `end_time`, not both",
                )),
                (None, None) => issues.push(DeckIssue::new(
                    &format!("{prefix}solver"),
                    "missing the run length: give `steps` or `end_time` (s)",
                )),
                (Some(0), None) => issues.push(DeckIssue::new(
                    &format!("{prefix}solver.steps"),
                    "expected at least 1 step, found 0",
                )),
                (None, Some(t)) => positive(
                    issues,
                    &format!("{prefix}solver.end_time"),
                    *t,
                    "end time (s)",
                ),
                _ => {}
            }
            if let Some(dt) = dt {
                positive(issues, &format!("{prefix}solver.dt"), *dt, "time step (s)");
            }
            if !(safety_factor.is_finite() && *safety_factor > 0.0 && *safety_factor <= 1.0) {
                issues.push(DeckIssue::new(
                    &format!("{prefix}solver.safety_factor"),
                    format!("safety factor must lie in (0, 1], found {safety_factor}"),
                ));
            }
            if !(damping.is_finite() && *damping >= 0.0) {
                issues.push(DeckIssue::new(
                    &format!("{prefix}solver.damping"),
                    format!("damping (1/s) must be zero or positive, found {damping}"),
                ));
            }
        }
        SolverDeck::QuasiStatic {
            load_steps,
            end_time,
            method,
            adr_damping,
            preconditioner,
            tolerance,
            max_iterations,
            mass_factor,
            max_equilibria,
            max_broken_bonds,
            stop_when_stored_below,
            ..
        } => {
            if *method == QuasiStaticMethod::Ncg && softens {
                issues.push(DeckIssue::new(
                    &format!("{prefix}solver.method"),
                    "conjugate gradients minimise a convex energy; a bilinear or trilinear softening law is not convex (seed 001 §2.10): use method = \"adr\"",
                ));
            }
            if *method == QuasiStaticMethod::Ncg && *adr_damping != AdrDampingDeck::Local {
                issues.push(DeckIssue::new(
                    &format!("{prefix}solver.adr_damping"),
                    "adr_damping sets the damping of adaptive dynamic relaxation; conjugate gradients have none: use method = \"adr\" or leave adr_damping out",
                ));
            }
            if *method != QuasiStaticMethod::Ncg && *preconditioner != PreconditionerDeck::Jacobi {
                issues.push(DeckIssue::new(
                    &format!("{prefix}solver.preconditioner"),
                    "preconditioner sets how conjugate gradients precondition; adaptive dynamic relaxation has fictitious masses instead: use method = \"ncg\" or leave preconditioner out",
                ));
            }
            if *load_steps == 0 {
                issues.push(DeckIssue::new(
                    &format!("{prefix}solver.load_steps"),
                    "expected at least 1 load step, found 0",
                ));
            }
            positive(
                issues,
                &format!("{prefix}solver.end_time"),
                *end_time,
                "load parameter at the end",
            );
            if !(tolerance.is_finite() && *tolerance > 0.0 && *tolerance < 1.0) {
                issues.push(DeckIssue::new(
                    &format!("{prefix}solver.tolerance"),
                    format!(
                        "the relative residual tolerance must lie in (0, 1), found {tolerance}"
                    ),
                ));
            }
            if *max_iterations == 0 || *max_equilibria == 0 {
                issues.push(DeckIssue::new(
                    &if *max_iterations == 0 {
                        format!("{prefix}solver.max_iterations")
                    } else {
                        format!("{prefix}solver.max_equilibria")
                    },
                    "expected at least 1",
                ));
            }
            if !(mass_factor.is_finite() && *mass_factor >= 1.0) {
                issues.push(DeckIssue::new(
                    &format!("{prefix}solver.mass_factor"),
                    format!("the fictitious mass factor must be at least 1 (the stability bound of dynamic relaxation), found {mass_factor}"),
                ));
            }
            if let Some(f) = stop_when_stored_below.filter(|f| !(*f > 0.0 && *f < 1.0)) {
                issues.push(DeckIssue::new(
                    &format!("{prefix}solver.stop_when_stored_below"),
                    format!("expected a fraction of the work done in (0, 1), e.g. 0.01, found {f}"),
                ));
            }
            if *max_broken_bonds == Some(0) {
                issues.push(DeckIssue::new(
                    &format!("{prefix}solver.max_broken_bonds"),
                    "expected at least 1 bond (or leave it out: never split a load step)",
                ));
            }
            for (k, bc) in conditions.iter().enumerate() {
                if bc.kind == Kinematic::Velocity {
                    issues.push(DeckIssue::new(
                        &format!("{at}boundary_conditions[{k}].kind"),
                        "a quasi-static run prescribes displacements; a velocity has no meaning without time (use kind = \"displacement\" with a ramp)",
                    ));
                }
            }
            if initial_velocities {
                issues.push(DeckIssue::new(
                    "initial_velocities",
                    "a quasi-static run has no velocities; remove initial_velocities or use the explicit solver",
                ));
            }
        }
    }
}

/// `[[stages]]`: each stage's solver under the boundary conditions it runs with (its own or
/// those it keeps from the stage before), its own loading keys.
fn validate_stages(
    issues: &mut Vec<DeckIssue>,
    deck: &Deck,
    softens: bool,
    known: &dyn Fn(&str) -> bool,
    unknown_set: &dyn Fn(&str) -> String,
) {
    let mut conditions = (String::new(), &deck.boundary_conditions);
    for (k, stage) in deck.stages.iter().enumerate() {
        let prefix = format!("stages[{k}].");
        if let Some(own) = &stage.boundary_conditions {
            conditions = (prefix.clone(), own);
        }
        validate_solver(
            issues,
            &prefix,
            &stage.solver,
            softens,
            (&conditions.0, conditions.1),
            false,
        );
        let none = Vec::new();
        validate_loading(
            issues,
            &prefix,
            (
                stage.no_fail.as_ref().unwrap_or(&none),
                stage.boundary_conditions.as_ref().unwrap_or(&Vec::new()),
                stage.loads.as_ref().unwrap_or(&Vec::new()),
            ),
            known,
            unknown_set,
            deck.dimension,
        );
    }
}

/// The no-fail sets, boundary conditions and loads of a stage; `prefix` is where they are
/// ("" for the deck's own, "stages[k]." for a later stage).
fn validate_loading(
    issues: &mut Vec<DeckIssue>,
    prefix: &str,
    (no_fail, conditions, loads): (&[String], &[BoundaryDeck], &[LoadDeck]),
    known: &dyn Fn(&str) -> bool,
    unknown_set: &dyn Fn(&str) -> String,
    d: usize,
) {
    for (k, name) in no_fail.iter().enumerate() {
        if !known(name) {
            issues.push(DeckIssue::new(
                &format!("{prefix}no_fail[{k}]"),
                unknown_set(name),
            ));
        }
    }
    for (k, bc) in conditions.iter().enumerate() {
        let p = format!("{prefix}boundary_conditions[{k}]");
        if !known(&bc.set) {
            issues.push(DeckIssue::new(&format!("{p}.set"), unknown_set(&bc.set)));
        }
        if bc.component.index() >= d {
            issues.push(DeckIssue::new(
                &format!("{p}.component"),
                format!(
                    "component \"{}\" does not exist in {d}D; expected \"x\" or \"y\"",
                    ["x", "y", "z"][bc.component.index()]
                ),
            ));
        }
        if !bc.value.is_finite() {
            issues.push(DeckIssue::new(
                &format!("{p}.value"),
                "expected a finite number",
            ));
        }
        if let Err(e) = bc.time.validate() {
            issues.push(DeckIssue::new(&format!("{p}.time"), e));
        }
        if let Some(g) = &bc.gradient {
            vector(issues, &format!("{p}.gradient"), g, d);
        }
        match (&bc.origin, &bc.gradient) {
            (Some(o), Some(_)) => vector(issues, &format!("{p}.origin"), o, d),
            (Some(_), None) => issues.push(DeckIssue::new(
                &format!("{p}.origin"),
                "an origin is where a gradient's term vanishes; give `gradient` too, or remove it",
            )),
            _ => {}
        }
    }
    for (k, load) in loads.iter().enumerate() {
        let p = format!("{prefix}loads[{k}]");
        let (set, value, time) = match load {
            LoadDeck::BodyForce { set, value, time } => (set, value, time),
            LoadDeck::Traction {
                set,
                value,
                time,
                area,
            } => {
                positive(issues, &format!("{p}.area"), *area, "loaded area (m²)");
                (set, value, time)
            }
        };
        if !known(set) {
            issues.push(DeckIssue::new(&format!("{p}.set"), unknown_set(set)));
        }
        vector(issues, &format!("{p}.value"), value, d);
        if let Err(e) = time.validate() {
            issues.push(DeckIssue::new(&format!("{p}.time"), e));
        }
    }
}

fn vector(out: &mut Vec<DeckIssue>, path: &str, v: &[f64], d: usize) {
    if v.len() != d {
        out.push(DeckIssue::new(
            path,
            format!("expected {d} components in a {d}D deck, found {}", v.len()),
        ));
    } else if v.iter().any(|x| !x.is_finite()) {
        out.push(DeckIssue::new(path, "expected finite numbers"));
    }
}

/// `[solver.adaptive]`.
fn validate_adaptive(out: &mut Vec<DeckIssue>, prefix: &str, a: &AdaptiveDtDeck) {
    let p = &format!("{prefix}solver.adaptive");
    if a.max_broken_per_node == 0 {
        out.push(DeckIssue::new(
            &format!("{p}.max_broken_per_node"),
            "expected at least 1 bond per node and step (0 would reject every step that breaks a bond)",
        ));
    }
    if a.stable_broken_per_node > a.max_broken_per_node {
        out.push(DeckIssue::new(
            &format!("{p}.stable_broken_per_node"),
            format!(
                "must not exceed max_broken_per_node ({}), found {}",
                a.max_broken_per_node, a.stable_broken_per_node
            ),
        ));
    }
    if !(a.reduce.is_finite() && a.reduce > 0.0 && a.reduce < 1.0) {
        out.push(DeckIssue::new(
            &format!("{p}.reduce"),
            format!("the reduce factor must lie in (0, 1), found {}", a.reduce),
        ));
    }
    if !(a.raise.is_finite() && a.raise > 1.0) {
        out.push(DeckIssue::new(
            &format!("{p}.raise"),
            format!("the raise factor must be above 1, found {}", a.raise),
        ));
    }
    for (key, v) in [("min_dt", a.min_dt), ("max_dt", a.max_dt)] {
        if let Some(v) = v {
            positive(out, &format!("{p}.{key}"), v, "time step (s)");
        }
    }
    if let (Some(lo), Some(hi)) = (a.min_dt, a.max_dt) {
        if lo > hi {
            out.push(DeckIssue::new(
                &format!("{p}.min_dt"),
                format!("min_dt ({lo:e} s) exceeds max_dt ({hi:e} s)"),
            ));
        }
    }
}
