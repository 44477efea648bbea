//! PNG maps of the snapshot fields chosen by `[output] maps`: the whole body in 2D, a slice
//! in 3D. Each map goes to `images/<field>_step_NNNNNNNN.png`, and its latest to `<field>.png`.

use super::observer::StepView;
use crate::atomic_file::with_path;
use crate::deck::schema::{MapField, MapSliceDeck, OutputDeck};
use crate::plot::colour_range::percentile_top;
use crate::plot::damage_map::{write_scalar_map_png, MapStyle};
use crate::plot::map_nodes::MapNodes;
use std::borrow::Cow;
use std::io;
use std::path::{Path, PathBuf};

/// Percentile of the strain energy density at the top of its colour bar: a crack tip's
/// concentration would otherwise leave the rest of the body in the darkest colour.
const ENERGY_PERCENTILE: f64 = 99.5;

pub struct FieldMaps {
    dir: PathBuf,
    fields: Vec<MapField>,
    slice: Option<MapSliceDeck>,
    title: String,
    /// Chosen at the first snapshot, from the body's reference positions.
    nodes: Option<MapNodes>,
}

impl FieldMaps {
    /// The maps `output` asks for, or `None` (no work at all) when `png` is off or the list
    /// is empty. Creates `dir/images`.
    pub fn new(dir: &Path, output: &OutputDeck, title: &str) -> io::Result<Option<Self>> {
        if !output.png || output.maps.is_empty() {
            return Ok(None);
        }
        let images = dir.join("images");
        std::fs::create_dir_all(&images)
            .map_err(|e| with_path(e, "cannot create directory", &images))?;
        Ok(Some(FieldMaps {
            dir: dir.to_path_buf(),
            fields: output.maps.clone(),
            slice: output.map_slice,
            title: title.to_string(),
            nodes: None,
        }))
    }

    /// Draws every chosen field of the view.
    pub fn write<const D: usize>(&mut self, view: &StepView<D>) -> io::Result<()> {
        let body = view.body;
        let slice = self.slice;
        let nodes = self.nodes.get_or_insert_with(|| match (D, slice) {
            (2, _) => MapNodes::whole(&body.positions, &body.cell_sizes),
            (_, s) => {
                let axis = s.map_or(2, |s| s.axis.index());
                MapNodes::slice(
                    &body.positions,
                    &body.cell_sizes,
                    axis,
                    s.and_then(|s| s.at),
                )
            }
        });
        if nodes.is_empty() {
            // The build refuses such a deck; this guards a body made without one.
            return Err(io::Error::other(format!(
                "[output] map_slice: no node lies on the plane {}; expected a plane through the body",
                nodes.plane_label()
            )));
        }
        let step = view.state.step;
        for &field in &self.fields {
            let (all, label, quantity): (Cow<[f64]>, _, _) = match field {
                MapField::Damage => (view.damage().into(), "damage (-)", "damage"),
                MapField::StrainEnergy => (
                    view.energy_density().into(),
                    "strain energy density W (J/m³)",
                    "strain energy density",
                ),
                MapField::Displacement => (
                    view.state.u.iter().map(|u| u.norm()).collect(),
                    "displacement |u| (m)",
                    "displacement",
                ),
            };
            // The range of the whole snapshot, so a slice's colours read as the body's.
            let vmax = match field {
                MapField::Damage => 1.0,
                MapField::StrainEnergy => percentile_top(&all, ENERGY_PERCENTILE),
                MapField::Displacement => percentile_top(&all, 100.0),
            };
            let values = nodes.pick(&all);
            let plane = nodes.plane_label();
            let title = format!(
                "{} — {quantity} at t = {:.3} µs (step {step}){}{plane}",
                self.title,
                view.state.time * 1e6,
                if plane.is_empty() { "" } else { ", " },
            );
            let style = MapStyle {
                outline: &[],
                fill_gaps: true,
                axis_names: nodes.axis_names,
                title: &title,
                label,
                vmin: 0.0,
                vmax,
                width_px: 1200,
            };
            let name = field.name();
            let path = self
                .dir
                .join("images")
                .join(format!("{name}_step_{step:08}.png"));
            write_scalar_map_png(&path, &nodes.xy, &nodes.cell_sizes, &values, &style)
                .map_err(|e| io::Error::other(e.to_string()))?;
            // The latest map, also replaced atomically.
            let bytes = std::fs::read(&path).map_err(|e| with_path(e, "cannot read", &path))?;
            crate::atomic_file::write_atomic(&self.dir.join(format!("{name}.png")), &bytes)?;
        }
        Ok(())
    }
}
