//! Field snapshots: VTU files in a PVD series, and a PNG damage map for 2D runs.

use super::observer::{Every, Observer, StepView};
use super::pvd::PvdSeries;
use super::vtu::{write_vtu, Field, FieldData};
use crate::math::to3;
use crate::plot::damage_map::{write_scalar_map_png, MapStyle};
use std::io;
use std::path::PathBuf;

pub struct Snapshots {
    dir: PathBuf,
    series: PvdSeries,
    every: Every,
    png: bool,
    title: String,
}

impl Snapshots {
    /// Writes `dir/fields/step_NNNNNNNN.vtu`, the series `dir/fields.pvd` and, in 2D when
    /// `png`, `dir/images/damage_step_NNNNNNNN.png` plus `dir/damage.png` (the latest).
    pub fn new(dir: PathBuf, every: u64, png: bool, title: &str) -> io::Result<Self> {
        let series = PvdSeries::new(dir.join("fields.pvd"));
        Self::with_series(dir, series, every, png, title)
    }

    /// The snapshots of a run continued at simulation time `time`: the series keeps its
    /// entries up to `time`; later snapshots are written again.
    pub fn resume(dir: PathBuf, time: f64, every: u64, png: bool, title: &str) -> io::Result<Self> {
        let series = PvdSeries::resume(dir.join("fields.pvd"), time)?;
        Self::with_series(dir, series, every, png, title)
    }

    fn with_series(
        dir: PathBuf,
        series: PvdSeries,
        every: u64,
        png: bool,
        title: &str,
    ) -> io::Result<Self> {
        std::fs::create_dir_all(dir.join("fields"))
            .map_err(|e| with_path(e, &dir.join("fields")))?;
        if png {
            std::fs::create_dir_all(dir.join("images"))
                .map_err(|e| with_path(e, &dir.join("images")))?;
        }
        Ok(Snapshots {
            series,
            dir,
            every: Every(every),
            png,
            title: title.to_string(),
        })
    }
}

fn with_path(e: io::Error, p: &std::path::Path) -> io::Error {
    io::Error::new(e.kind(), format!("{}: {e}", p.display()))
}

impl<const D: usize> Observer<D> for Snapshots {
    fn wants(&self, step: u64, last: bool) -> bool {
        self.every.hits(step, last)
    }

    fn observe(&mut self, view: &StepView<D>) -> io::Result<()> {
        let step = view.state.step;
        let points: Vec<[f64; 3]> = view.body.positions.iter().map(to3).collect();
        let flat = |v: &[crate::math::Vector<D>]| {
            v.iter()
                .flat_map(|x| x.iter().cloned().collect::<Vec<_>>())
                .collect::<Vec<f64>>()
        };
        let (u, v) = (flat(&view.state.u), flat(&view.state.v));
        let blocks: Vec<i32> = view.body.blocks.iter().map(|&b| b as i32).collect();
        let name = format!("step_{step:08}.vtu");
        write_vtu(
            &self.dir.join("fields").join(&name),
            &points,
            &[
                Field {
                    name: "displacement",
                    data: FieldData::Vector {
                        data: &u,
                        components: D,
                    },
                },
                Field {
                    name: "velocity",
                    data: FieldData::Vector {
                        data: &v,
                        components: D,
                    },
                },
                Field {
                    name: "damage",
                    data: FieldData::Scalar(view.damage()),
                },
                Field {
                    name: "strain_energy_density",
                    data: FieldData::Scalar(view.energy_density()),
                },
                Field {
                    name: "block",
                    data: FieldData::Int(&blocks),
                },
            ],
        )?;
        self.series
            .add(view.state.time, &format!("fields/{name}"))?;
        if D == 2 && self.png {
            let xy: Vec<[f64; 2]> = view.body.positions.iter().map(|p| [p[0], p[1]]).collect();
            let title = format!(
                "{} — damage at t = {:.3} µs (step {step})",
                self.title,
                view.state.time * 1e6
            );
            let style = MapStyle {
                outline: &[],
                fill_gaps: true,
                title: &title,
                label: "damage (-)",
                vmin: 0.0,
                vmax: 1.0,
                width_px: 1200,
            };
            let path = self
                .dir
                .join("images")
                .join(format!("damage_step_{step:08}.png"));
            write_scalar_map_png(&path, &xy, &view.body.cell_sizes, view.damage(), &style)
                .map_err(|e| io::Error::other(e.to_string()))?;
            // The latest map, also replaced atomically.
            let bytes = std::fs::read(&path).map_err(|e| with_path(e, &path))?;
            crate::atomic_file::write_atomic(&self.dir.join("damage.png"), &bytes)?;
        }
        Ok(())
    }
}
