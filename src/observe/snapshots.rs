//! Field snapshots: VTU files in a PVD series, and the PNG field maps of `[output] maps`.

use super::field_maps::FieldMaps;
use super::observer::{Every, Observer, StepView};
use super::pvd::PvdSeries;
use super::vtu::{write_vtu, Field, FieldData};
use crate::atomic_file::with_path;
use crate::deck::schema::OutputDeck;
use crate::math::to3;
use std::io;
use std::path::{Path, PathBuf};

pub struct Snapshots {
    dir: PathBuf,
    series: PvdSeries,
    every: Every,
    /// `None` when no map is wanted: then maps cost nothing.
    maps: Option<FieldMaps>,
}

impl Snapshots {
    /// Writes `dir/fields/step_NNNNNNNN.vtu`, the series `dir/fields.pvd` and the maps
    /// `output` asks for (see `FieldMaps`).
    pub fn new(dir: PathBuf, every: u64, output: &OutputDeck, title: &str) -> io::Result<Self> {
        let series = PvdSeries::new(dir.join("fields.pvd"));
        Self::with_series(dir, series, every, output, title)
    }

    /// The snapshots of a run continued at simulation time `time`: the series keeps its
    /// entries up to `time`; later snapshots are written again.
    pub fn resume(
        dir: PathBuf,
        time: f64,
        every: u64,
        output: &OutputDeck,
        title: &str,
    ) -> io::Result<Self> {
        let series = PvdSeries::resume(dir.join("fields.pvd"), time)?;
        Self::with_series(dir, series, every, output, title)
    }

    fn with_series(
        dir: PathBuf,
        series: PvdSeries,
        every: u64,
        output: &OutputDeck,
        title: &str,
    ) -> io::Result<Self> {
        std::fs::create_dir_all(dir.join("fields"))
            .map_err(|e| with_path(e, "cannot create directory", &dir.join("fields")))?;
        Ok(Snapshots {
            series,
            maps: FieldMaps::new(&dir, output, title)?,
            dir,
            every: Every(every),
        })
    }
}

impl<const D: usize> Observer<D> for Snapshots {
    fn wants(&self, step: u64, last: bool) -> bool {
        self.every.hits(step, last)
    }

    fn observe(&mut self, view: &StepView<D>) -> io::Result<()> {
        let name = format!("step_{:08}.vtu", view.state.step);
        write_fields(&self.dir.join("fields").join(&name), view)?;
        self.series
            .add(view.state.time, &format!("fields/{name}"))?;
        if let Some(maps) = &mut self.maps {
            maps.write(view)?;
        }
        Ok(())
    }
}

/// Writes the fields of `view` (displacement, velocity, damage, strain energy density, block)
/// as one VTU file.
pub fn write_fields<const D: usize>(path: &Path, view: &StepView<D>) -> io::Result<()> {
    let points: Vec<[f64; 3]> = view.body.positions.iter().map(to3).collect();
    let flat = |v: &[crate::math::Vector<D>]| {
        v.iter()
            .flat_map(|x| x.iter().cloned().collect::<Vec<_>>())
            .collect::<Vec<f64>>()
    };
    let (u, v) = (flat(&view.state.u), flat(&view.state.v));
    let blocks: Vec<i32> = view.body.blocks.iter().map(|&b| b as i32).collect();
    write_vtu(
        path,
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
    )
}
