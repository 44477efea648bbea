//! Field snapshots: VTU files in a PVD series, and the PNG field maps of `[output] maps`.
//! With `[output] pieces = "per_rank"` each snapshot is a `.pvtu` of one VTU piece per rank:
//! one process writes its one piece here; a distributed run's ranks write theirs
//! (`distributed::gather`) and rank 0 the `.pvtu`.

use super::field_maps::FieldMaps;
use super::observer::{Every, Observer, StepView};
use super::pvd::PvdSeries;
use super::vtu::{write_pvtu, write_vtu, Field, FieldData};
use crate::atomic_file::with_path;
use crate::deck::schema::{OutputDeck, Pieces};
use crate::math::{to3, Vector};
use std::io;
use std::path::{Path, PathBuf};

pub struct Snapshots {
    dir: PathBuf,
    series: PvdSeries,
    every: Every,
    /// `None` when no map is wanted: then maps cost nothing.
    maps: Option<FieldMaps>,
    /// With `[output] pieces = "per_rank"`: the pieces of each snapshot (the ranks).
    pieces: Option<usize>,
}

/// With pieces, the largest body whose PNG maps are drawn: rank 0 gathers every node's
/// fields for them (about 1 GB of fields and map nodes at this size in 3D).
pub const MAP_NODE_LIMIT: usize = 4_000_000;

/// Whether a body of `nodes` nodes skips the maps `output` asks for (pieces above
/// `MAP_NODE_LIMIT`), whatever the number of ranks.
pub fn maps_skipped(output: &OutputDeck, nodes: usize) -> bool {
    output.pieces == Pieces::PerRank
        && output.png
        && !output.maps.is_empty()
        && nodes > MAP_NODE_LIMIT
}

/// The note summary.txt carries when the maps are skipped.
pub fn maps_skipped_note(nodes: usize) -> String {
    format!(
        "PNG maps skipped: {nodes} nodes with pieces = \"per_rank\" (drawn up to {MAP_NODE_LIMIT})"
    )
}

/// The file of `rank`'s piece of the snapshot of `step`, in `fields/`.
pub fn piece_name(step: u64, rank: usize) -> String {
    format!("step_{step:08}_piece_{rank}.vtu")
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
            pieces: (output.pieces == Pieces::PerRank).then_some(1),
        })
    }

    /// The snapshots of a body of `nodes` nodes on `ranks` ranks (each writes its own piece
    /// when there are pieces; with more than one rank, not these snapshots) with `output`'s
    /// maps unless `maps_skipped`.
    pub fn on_ranks(mut self, ranks: usize, nodes: usize, output: &OutputDeck) -> Self {
        if let Some(p) = &mut self.pieces {
            *p = ranks;
        }
        if maps_skipped(output, nodes) {
            self.maps = None;
        }
        self
    }
}

impl<const D: usize> Observer<D> for Snapshots {
    fn wants(&self, step: u64, last: bool) -> bool {
        self.every.hits(step, last)
    }

    fn observe(&mut self, view: &StepView<D>) -> io::Result<()> {
        let step = view.state.step;
        let fields = self.dir.join("fields");
        let name = match self.pieces {
            None => {
                let name = format!("step_{step:08}.vtu");
                write_fields(&fields.join(&name), view)?;
                name
            }
            Some(pieces) => {
                if pieces == 1 {
                    write_fields(&fields.join(piece_name(step, 0)), view)?;
                }
                let name = format!("step_{step:08}.pvtu");
                let sources: Vec<String> = (0..pieces).map(|r| piece_name(step, r)).collect();
                let none = NodeFields::<D>::default();
                write_pvtu(&fields.join(&name), &none.fields(), &sources)?;
                name
            }
        };
        self.series
            .add(view.state.time, &format!("fields/{name}"))?;
        if let Some(maps) = &mut self.maps {
            maps.write(view)?;
        }
        Ok(())
    }

    /// The maps read every node's fields; pieces from several ranks are not written here.
    fn reads_fields(&self) -> bool {
        self.maps.is_some() || self.pieces.is_none_or(|p| p == 1)
    }
}

/// Writes the fields of `view` (displacement, velocity, damage, strain energy density, block)
/// as one VTU file.
pub fn write_fields<const D: usize>(path: &Path, view: &StepView<D>) -> io::Result<()> {
    let n = view.body.len();
    NodeFields::of(
        (&view.body.positions, &view.body.blocks),
        (&view.state.u, &view.state.v),
        (view.damage(), view.energy_density()),
        n,
    )
    .write(path)
}

/// The snapshot fields of a run of nodes (a whole body, or a rank's owned nodes), flattened
/// as the VTU file stores them.
#[derive(Default)]
pub struct NodeFields<const D: usize> {
    points: Vec<[f64; 3]>,
    u: Vec<f64>,
    v: Vec<f64>,
    damage: Vec<f64>,
    energy: Vec<f64>,
    blocks: Vec<i32>,
}

impl<const D: usize> NodeFields<D> {
    /// The first `n` nodes of the slices: reference positions and blocks, displacement and
    /// velocity, damage and strain energy density.
    pub fn of(
        (positions, blocks): (&[Vector<D>], &[u32]),
        (u, v): (&[Vector<D>], &[Vector<D>]),
        (damage, energy): (&[f64], &[f64]),
        n: usize,
    ) -> Self {
        let flat = |x: &[Vector<D>]| x[..n].iter().flat_map(|x| x.iter().copied()).collect();
        NodeFields {
            points: positions[..n].iter().map(to3).collect(),
            u: flat(u),
            v: flat(v),
            damage: damage[..n].to_vec(),
            energy: energy[..n].to_vec(),
            blocks: blocks[..n].iter().map(|&b| b as i32).collect(),
        }
    }

    /// The fields as the VTU file names them, in its order.
    fn fields(&self) -> [Field<'_>; 5] {
        let vector = |data| FieldData::Vector {
            data,
            components: D,
        };
        [
            Field {
                name: "displacement",
                data: vector(&self.u),
            },
            Field {
                name: "velocity",
                data: vector(&self.v),
            },
            Field {
                name: "damage",
                data: FieldData::Scalar(&self.damage),
            },
            Field {
                name: "strain_energy_density",
                data: FieldData::Scalar(&self.energy),
            },
            Field {
                name: "block",
                data: FieldData::Int(&self.blocks),
            },
        ]
    }

    /// Writes them as one VTU file (atomically).
    pub fn write(&self, path: &Path) -> io::Result<()> {
        write_vtu(path, &self.points, &self.fields())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atomic_file::test_dir;

    #[test]
    fn maps_are_skipped_only_for_large_bodies_in_pieces() {
        let mut output = OutputDeck::default();
        assert!(!maps_skipped(&output, MAP_NODE_LIMIT + 1), "gathered");
        output.pieces = Pieces::PerRank;
        assert!(!maps_skipped(&output, MAP_NODE_LIMIT));
        assert!(maps_skipped(&output, MAP_NODE_LIMIT + 1));
        output.maps.clear();
        assert!(
            !maps_skipped(&output, MAP_NODE_LIMIT + 1),
            "no maps asked for"
        );
        assert!(maps_skipped_note(5_000_000).contains("4000000"));
    }

    #[test]
    fn a_pvtu_names_its_pieces_and_declares_the_pieces_arrays() {
        let dir = test_dir("pvtu");
        let path = dir.join("step_00000010.pvtu");
        let sources: Vec<String> = (0..3).map(|r| piece_name(10, r)).collect();
        write_pvtu(&path, &NodeFields::<2>::default().fields(), &sources).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("<VTKFile type=\"PUnstructuredGrid\""));
        let pieces: Vec<&str> = text.lines().filter(|l| l.contains("<Piece")).collect();
        assert_eq!(
            pieces,
            [
                "    <Piece Source=\"step_00000010_piece_0.vtu\"/>",
                "    <Piece Source=\"step_00000010_piece_1.vtu\"/>",
                "    <Piece Source=\"step_00000010_piece_2.vtu\"/>"
            ]
        );
        // 2D vectors are written with three components, as in the pieces.
        assert!(text.contains(
            "<PDataArray type=\"Float64\" Name=\"displacement\" NumberOfComponents=\"3\"/>"
        ));
        assert!(
            text.contains("<PDataArray type=\"Int32\" Name=\"block\" NumberOfComponents=\"1\"/>")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_piece_is_the_first_nodes_of_the_fields() {
        let v = |x: f64| Vector::<2>::new(x, -x);
        let positions = [v(0.0), v(1.0), v(2.0)];
        let (u, vel) = ([v(3.0), v(4.0), v(5.0)], [v(6.0), v(7.0), v(8.0)]);
        let piece = NodeFields::of(
            (&positions, &[0, 1, 2]),
            (&u, &vel),
            (&[0.1, 0.2, 0.3], &[1.0, 2.0, 3.0]),
            2,
        );
        assert_eq!(piece.points, [[0.0, 0.0, 0.0], [1.0, -1.0, 0.0]]);
        assert_eq!(piece.u, [3.0, -3.0, 4.0, -4.0]);
        assert_eq!(piece.v, [6.0, -6.0, 7.0, -7.0]);
        assert_eq!(
            (piece.damage, piece.energy),
            (vec![0.1, 0.2], vec![1.0, 2.0])
        );
        assert_eq!(piece.blocks, [0, 1]);
    }
}
