//! Physics and consistency checks on a parsed deck. Each issue carries the key path and says
//! what was found and what is expected.

use super::schema::*;
use super::DeckIssue;
use crate::material::pmb::bond_based_poisson_ratio;
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

/// All problems found; empty if the deck is usable.
pub fn validate(deck: &Deck) -> Vec<DeckIssue> {
    let mut out = Vec::new();
    let d = deck.dimension;
    if deck.version != 1 {
        out.push(DeckIssue::new(
            "version",
            format!(
                "unsupported deck version {}; this peridyn reads version = 1",
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
            ..
        } => {
            check_shape(&mut out, "discretization.shape", shape);
            positive(
                &mut out,
                "discretization.spacing",
                *spacing,
                "lattice spacing (m)",
            );
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
                    positive(&mut out, "discretization.horizon", *h, "horizon (m)");
                    if *h > 0.0 && *spacing > 0.0 && *h < *spacing {
                        out.push(DeckIssue::new("discretization.horizon", format!("horizon {h} m is smaller than the spacing {spacing} m (δ/Δx = {:.3}); peridynamics needs δ/Δx ≥ 1, typically 3 to 4", h / spacing)));
                    }
                }
                (None, Some(r)) => {
                    positive(
                        &mut out,
                        "discretization.horizon_ratio",
                        *r,
                        "horizon ratio δ/Δx",
                    );
                    if r.is_finite() && *r > 0.0 && *r < 1.0 {
                        out.push(DeckIssue::new("discretization.horizon_ratio", format!("δ/Δx = {r} makes the horizon smaller than the spacing; expected at least 1, typically 3 to 4")));
                    }
                }
            }
        }
        Discretization::PointCloud { file, horizon, .. } => {
            if file.trim().is_empty() {
                out.push(DeckIssue::new(
                    "discretization.file",
                    "expected the path of a point-cloud file",
                ));
            }
            positive(&mut out, "discretization.horizon", *horizon, "horizon (m)");
        }
    }

    match &deck.material {
        MaterialDeck::Pmb {
            density,
            youngs_modulus,
            micromodulus,
            poisson_ratio,
            fracture_energy,
            critical_stretch,
            ..
        } => {
            positive(&mut out, "material.density", *density, "density (kg/m³)");
            match (youngs_modulus, micromodulus) {
                (Some(_), Some(_)) => out.push(DeckIssue::new(
                    "material.micromodulus",
                    "give `youngs_modulus` or `micromodulus`, not both",
                )),
                (None, None) => out.push(DeckIssue::new(
                    "material",
                    "missing stiffness: give `youngs_modulus` (Pa) or `micromodulus`",
                )),
                (Some(e), None) => positive(
                    &mut out,
                    "material.youngs_modulus",
                    *e,
                    "Young's modulus (Pa)",
                ),
                (None, Some(c)) => positive(&mut out, "material.micromodulus", *c, "micromodulus"),
            }
            if let (Some(nu), Some(dm)) = (poisson_ratio, dimensionality) {
                let fixed = bond_based_poisson_ratio(dm);
                if (nu - fixed).abs() > 1e-6 {
                    out.push(DeckIssue::new(
                        "material.poisson_ratio",
                        format!("bond-based PMB fixes Poisson's ratio at {fixed:.4} in {}; found {nu}. Use type = \"lps\" for another Poisson ratio", dm.describe()),
                    ));
                }
            }
            fracture(&mut out, fracture_energy, critical_stretch);
        }
        MaterialDeck::Lps {
            density,
            youngs_modulus,
            poisson_ratio,
            fracture_energy,
            critical_stretch,
            ..
        } => {
            positive(&mut out, "material.density", *density, "density (kg/m³)");
            positive(
                &mut out,
                "material.youngs_modulus",
                *youngs_modulus,
                "Young's modulus (Pa)",
            );
            if !(poisson_ratio.is_finite() && *poisson_ratio > -1.0 && *poisson_ratio < 0.5) {
                out.push(DeckIssue::new("material.poisson_ratio", format!("Poisson's ratio must lie in (-1, 0.5) for a stable isotropic solid, found {poisson_ratio}")));
            }
            fracture(&mut out, fracture_energy, critical_stretch);
        }
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
    let known = |name: &str| name == "all" || names.contains(&name);
    let unknown_set = |name: &str| {
        format!(
            "unknown node set {name:?}; defined sets: all{}",
            names.iter().map(|n| format!(", {n}")).collect::<String>()
        )
    };

    for (k, b) in deck.blocks.iter().enumerate() {
        check_shape(&mut out, &format!("blocks[{k}].region"), &b.region);
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
    for (k, name) in deck.no_fail.iter().enumerate() {
        if !known(name) {
            out.push(DeckIssue::new(&format!("no_fail[{k}]"), unknown_set(name)));
        }
    }
    for (k, bc) in deck.boundary_conditions.iter().enumerate() {
        let p = format!("boundary_conditions[{k}]");
        if !known(&bc.set) {
            out.push(DeckIssue::new(&format!("{p}.set"), unknown_set(&bc.set)));
        }
        if bc.component.index() >= d {
            out.push(DeckIssue::new(
                &format!("{p}.component"),
                format!(
                    "component \"{}\" does not exist in {d}D; expected \"x\" or \"y\"",
                    ["x", "y", "z"][bc.component.index()]
                ),
            ));
        }
        if !bc.value.is_finite() {
            out.push(DeckIssue::new(
                &format!("{p}.value"),
                "expected a finite number",
            ));
        }
        if let Err(e) = bc.time.validate() {
            out.push(DeckIssue::new(&format!("{p}.time"), e));
        }
    }
    for (k, load) in deck.loads.iter().enumerate() {
        let p = format!("loads[{k}]");
        let (set, value, time) = match load {
            LoadDeck::BodyForce { set, value, time } => (set, value, time),
            LoadDeck::Traction {
                set,
                value,
                time,
                area,
            } => {
                positive(&mut out, &format!("{p}.area"), *area, "loaded area (m²)");
                (set, value, time)
            }
        };
        if !known(set) {
            out.push(DeckIssue::new(&format!("{p}.set"), unknown_set(set)));
        }
        vector(&mut out, &format!("{p}.value"), value, d);
        if let Err(e) = time.validate() {
            out.push(DeckIssue::new(&format!("{p}.time"), e));
        }
    }
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

    match &deck.solver {
        SolverDeck::Explicit {
            steps,
            end_time,
            dt,
            safety_factor,
            damping,
        } => {
            match (steps, end_time) {
                (Some(_), Some(_)) => out.push(DeckIssue::new(
                    "solver.end_time",
                    "give `steps` or `end_time`, not both",
                )),
                (None, None) => out.push(DeckIssue::new(
                    "solver",
                    "missing the run length: give `steps` or `end_time` (s)",
                )),
                (Some(0), None) => out.push(DeckIssue::new(
                    "solver.steps",
                    "expected at least 1 step, found 0",
                )),
                (None, Some(t)) => positive(&mut out, "solver.end_time", *t, "end time (s)"),
                _ => {}
            }
            if let Some(dt) = dt {
                positive(&mut out, "solver.dt", *dt, "time step (s)");
            }
            if !(safety_factor.is_finite() && *safety_factor > 0.0 && *safety_factor <= 1.0) {
                out.push(DeckIssue::new(
                    "solver.safety_factor",
                    format!("safety factor must lie in (0, 1], found {safety_factor}"),
                ));
            }
            if !(damping.is_finite() && *damping >= 0.0) {
                out.push(DeckIssue::new(
                    "solver.damping",
                    format!("damping (1/s) must be zero or positive, found {damping}"),
                ));
            }
        }
    }
    out
}

fn fracture(out: &mut Vec<DeckIssue>, g0: &Option<f64>, s0: &Option<f64>) {
    match (g0, s0) {
        (Some(_), Some(_)) => out.push(DeckIssue::new(
            "material.critical_stretch",
            "give `fracture_energy` or `critical_stretch`, not both",
        )),
        (Some(g), None) => positive(
            out,
            "material.fracture_energy",
            *g,
            "fracture energy G0 (J/m²)",
        ),
        (None, Some(s)) => positive(out, "material.critical_stretch", *s, "critical stretch"),
        (None, None) => {}
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
