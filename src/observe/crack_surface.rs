//! The crack as a surface during a 3D run (`[analysis.crack_surface]`): every `interval` steps
//! the crack area is estimated from the broken half-bonds (`analysis::crack_area`) and
//! recorded with the energy dissipated by damage, giving Γ = dE_diss/dA (seed 002 Eq. 13 in
//! its 3D form, the crack area in place of ā); the surface of the last sample is binned on a
//! grid normal to `axis` (`analysis::crack_surface`). Files, written atomically at every
//! flush and at the end: `crack_area.csv`, `crack_surface.csv`, `crack_surface.vtu`.
//!
//! The broken halves are read from the step's view (`Fields::broken_halves`: in one process
//! from the bonds and their quadrature weights; in a distributed run each rank's rows,
//! gathered to rank 0 in rank order). Its scans run sequentially in node and bond order, so
//! the files are the same for any number of threads and ranks. A restart reads the area
//! history back from `crack_area.csv`; the surface is recomputed from the state at the next
//! sample.

use super::csv::push_number;
use super::observer::{Every, Observer, StepView};
use super::resume::{cannot_continue, rows_up_to};
use crate::analysis::{crack_area, crack_surface, in_plane_axes, BrokenHalf, SurfaceCell};
use crate::atomic_file::write_atomic;
use crate::body::Body;
use crate::bonds::Quadrature;
use crate::state::OWN_BROKEN;
use std::cell::RefCell;
use std::fmt::Write as _;
use std::io;
use std::path::{Path, PathBuf};
use std::rc::Rc;

const AXES: [&str; 3] = ["x", "y", "z"];

/// The broken halves of a state, in node then bond order: every directed entry i→j whose own
/// half is broken (`OWN_BROKEN`, as the damage field counts it), weighted φ_ij V_i V_j with
/// the engine's partial-volume factor. `offsets` and `neighbors` are the families' CSR
/// arrays (`Bonds`); the reference length is recomputed as the search computes it.
pub fn broken_halves<const D: usize>(
    body: &Body<D>,
    offsets: &[usize],
    neighbors: &[u32],
    quad: &Quadrature,
    status: &[u8],
) -> Vec<BrokenHalf<D>> {
    let mut out = Vec::new();
    for i in 0..offsets.len().saturating_sub(1) {
        for b in offsets[i]..offsets[i + 1] {
            if status[b] & OWN_BROKEN == 0 {
                continue;
            }
            let j = neighbors[b] as usize;
            let (xi, xj) = (body.positions[i], body.positions[j]);
            let len = (xj - xi).norm();
            let phi = quad.phi_pair(b, i, j, len).0;
            out.push(BrokenHalf {
                owner: xi,
                neighbour: xj,
                weight: phi * body.volumes[i] * body.volumes[j],
                horizon: body.horizons[i],
            });
        }
    }
    out
}

/// Settings of the analysis.
#[derive(Debug, Clone)]
pub struct SurfaceSettings {
    /// The crack's mean normal: 0 = x, 1 = y, 2 = z.
    pub axis: usize,
    /// Cell side (m).
    pub bin_width: f64,
    /// Steps between area samples (the last step is always sampled).
    pub interval: u64,
    /// G0 (J/m²) to compare Γ with, when the deck gives it.
    pub g0: Option<f64>,
}

/// What the analysis found, for the run summary.
#[derive(Debug, Clone, PartialEq)]
pub struct CrackSurfaceReport {
    /// Crack area of the last sample (m²).
    pub area: f64,
    /// Energy dissipated by damage at the last sample (J).
    pub dissipated: f64,
    /// Cells of the final surface.
    pub cells: usize,
    pub g0: Option<f64>,
}

impl std::fmt::Display for CrackSurfaceReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "area {:.4} mm² in {} cells, dissipated {:.4e} J",
            self.area * 1e6,
            self.cells,
            self.dissipated
        )?;
        if self.area > 0.0 {
            write!(f, ", E_diss/A = {:.4e} J/m²", self.dissipated / self.area)?;
            if let Some(g0) = self.g0 {
                write!(f, " = {:.3} G0", self.dissipated / self.area / g0)?;
            }
        }
        Ok(())
    }
}

/// One sample of the area history.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sample {
    time: f64,
    step: u64,
    area: f64,
    dissipated: f64,
}

/// The crack-surface observer: samples in memory, files at every flush and at the end.
pub struct CrackSurface {
    settings: SurfaceSettings,
    every: Every,
    dir: PathBuf,
    thickness: f64,
    samples: Vec<Sample>,
    cells: Vec<SurfaceCell>,
    report: Rc<RefCell<Option<CrackSurfaceReport>>>,
}

impl CrackSurface {
    /// Writes into `dir`.
    pub fn new<const D: usize>(dir: &Path, body: &Body<D>, settings: SurfaceSettings) -> Self {
        CrackSurface {
            every: Every(settings.interval),
            settings,
            dir: dir.to_path_buf(),
            thickness: body.thickness,
            samples: Vec::new(),
            cells: Vec::new(),
            report: Rc::new(RefCell::new(None)),
        }
    }

    /// Where `finish` leaves the report.
    pub fn report(&self) -> Rc<RefCell<Option<CrackSurfaceReport>>> {
        Rc::clone(&self.report)
    }

    /// Continues after a restart at `step`: the samples up to `step` are read back from
    /// `crack_area.csv` (written at every flush, so before every checkpoint); the rates are
    /// recomputed from them when the file is written again.
    pub fn resume(mut self, step: u64) -> io::Result<Self> {
        let path = self.dir.join("crack_area.csv");
        let text = std::fs::read_to_string(&path)
            .map_err(|e| crate::atomic_file::with_path(e, "cannot read", &path))?;
        for line in rows_up_to(&text, step, &path)?.lines().skip(1) {
            let cells: Vec<Option<f64>> = line.split(',').map(|c| c.parse::<f64>().ok()).collect();
            let [Some(time), Some(s), Some(area), Some(dissipated), ..] = cells[..] else {
                return Err(cannot_continue(
                    &path,
                    format!(
                        "expected time, step, crack area and dissipated energy, found {line:?}"
                    ),
                ));
            };
            self.samples.push(Sample {
                time,
                step: s as u64,
                area,
                dissipated,
            });
        }
        Ok(self)
    }

    /// `crack_area.csv`: each sample, and from the second on Γ = ΔE_diss/ΔA over the interval
    /// since the one before (seed 002 Eq. 13 with the crack area for ā), empty where the area
    /// did not grow; Γ/G0 when G0 is known.
    fn render_area(&self) -> String {
        let mut s =
            String::from("time,step,crack_area,damage_dissipation,dissipation_rate,rate_over_g0\n");
        let mut previous: Option<&Sample> = None;
        for smp in &self.samples {
            push_number(&mut s, smp.time);
            s.push(',');
            push_number(&mut s, smp.step as f64);
            s.push(',');
            push_number(&mut s, smp.area);
            s.push(',');
            push_number(&mut s, smp.dissipated);
            s.push(',');
            let rate = previous.and_then(|p| {
                let da = smp.area - p.area;
                (da > 0.0).then(|| (smp.dissipated - p.dissipated) / da)
            });
            if let Some(g) = rate {
                push_number(&mut s, g);
            }
            s.push(',');
            if let (Some(g), Some(g0)) = (rate, self.settings.g0) {
                push_number(&mut s, g / g0);
            }
            s.push('\n');
            previous = Some(smp);
        }
        s
    }

    /// `crack_surface.csv`: per cell its centre's two in-plane coordinates, the surface's
    /// coordinate along the axis and the cell's crack area.
    fn render_cells(&self) -> String {
        let axis = self.settings.axis;
        let (a, b) = in_plane_axes(axis);
        let mut s = format!("{},{},{},area\n", AXES[a], AXES[b], AXES[axis]);
        for c in &self.cells {
            for (k, v) in [c.centre.0, c.centre.1, c.height, c.area]
                .into_iter()
                .enumerate()
            {
                if k > 0 {
                    s.push(',');
                }
                push_number(&mut s, v);
            }
            s.push('\n');
        }
        s
    }

    /// `crack_surface.vtu` (ASCII): each cell a quad at its mean height, with its area and
    /// height as cell data. (The shared writer in `vtu.rs` writes point clouds of vertices.)
    fn render_vtu(&self) -> String {
        let axis = self.settings.axis;
        let (a, b) = in_plane_axes(axis);
        let h = self.settings.bin_width;
        let n = self.cells.len();
        let mut s = String::new();
        let _ = writeln!(s, "<?xml version=\"1.0\"?>");
        let _ = writeln!(
            s,
            "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">"
        );
        let _ = writeln!(s, "  <UnstructuredGrid>");
        let _ = writeln!(
            s,
            "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{n}\">",
            4 * n
        );
        let _ = writeln!(s, "      <CellData Scalars=\"area\">");
        for (name, pick) in [("area", 0), ("height", 1)] {
            let _ = write!(
                s,
                "        <DataArray type=\"Float64\" Name=\"{name}\" format=\"ascii\">"
            );
            for c in &self.cells {
                s.push(' ');
                push_number(&mut s, if pick == 0 { c.area } else { c.height });
            }
            let _ = writeln!(s, " </DataArray>");
        }
        let _ = writeln!(s, "      </CellData>");
        let _ = writeln!(s, "      <Points>");
        let _ = write!(
            s,
            "        <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">"
        );
        for c in &self.cells {
            let (ka, kb) = (c.index.0 as f64, c.index.1 as f64);
            for (da, db) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
                let mut p = [0.0; 3];
                p[a] = (ka + da) * h;
                p[b] = (kb + db) * h;
                p[axis] = c.height;
                for v in p {
                    s.push(' ');
                    push_number(&mut s, v);
                }
            }
        }
        let _ = writeln!(s, " </DataArray>");
        let _ = writeln!(s, "      </Points>");
        let _ = writeln!(s, "      <Cells>");
        let _ = write!(
            s,
            "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">"
        );
        for k in 0..4 * n {
            let _ = write!(s, " {k}");
        }
        let _ = writeln!(s, " </DataArray>");
        let _ = write!(
            s,
            "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">"
        );
        for k in 1..=n {
            let _ = write!(s, " {}", 4 * k);
        }
        let _ = writeln!(s, " </DataArray>");
        // VTK_QUAD = 9.
        let _ = write!(
            s,
            "        <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">"
        );
        for _ in 0..n {
            s.push_str(" 9");
        }
        let _ = writeln!(s, " </DataArray>");
        let _ = writeln!(s, "      </Cells>");
        let _ = writeln!(s, "    </Piece>");
        let _ = writeln!(s, "  </UnstructuredGrid>");
        let _ = writeln!(s, "</VTKFile>");
        s
    }
}

impl<const D: usize> Observer<D> for CrackSurface {
    fn wants(&self, step: u64, last: bool) -> bool {
        D == 3 && self.every.hits(step, last)
    }

    fn reads_broken_bonds(&self) -> bool {
        true
    }

    fn observe(&mut self, view: &StepView<D>) -> io::Result<()> {
        let t = view.state.time;
        // A step offered twice (a stage's end) adds nothing.
        if self.samples.last().is_some_and(|s| t <= s.time) {
            return Ok(());
        }
        let halves = view.broken_halves();
        self.samples.push(Sample {
            time: t,
            step: view.state.step,
            area: crack_area(&halves, self.thickness),
            dissipated: view.damage_dissipation(),
        });
        if D == 3 {
            let halves3: Vec<BrokenHalf<3>> = halves
                .iter()
                .map(|h| BrokenHalf {
                    owner: crate::math::vector_from_slice::<3>(h.owner.as_slice()),
                    neighbour: crate::math::vector_from_slice::<3>(h.neighbour.as_slice()),
                    weight: h.weight,
                    horizon: h.horizon,
                })
                .collect();
            self.cells = crack_surface(&halves3, self.settings.axis, self.settings.bin_width);
        }
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        write_atomic(
            &self.dir.join("crack_area.csv"),
            self.render_area().as_bytes(),
        )?;
        write_atomic(
            &self.dir.join("crack_surface.csv"),
            self.render_cells().as_bytes(),
        )?;
        write_atomic(
            &self.dir.join("crack_surface.vtu"),
            self.render_vtu().as_bytes(),
        )?;
        let last = self.samples.last().copied();
        *self.report.borrow_mut() = Some(CrackSurfaceReport {
            area: last.map_or(0.0, |s| s.area),
            dissipated: last.map_or(0.0, |s| s.dissipated),
            cells: self.cells.len(),
            g0: self.settings.g0,
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn observer(dir: &Path) -> CrackSurface {
        CrackSurface {
            settings: SurfaceSettings {
                axis: 1,
                bin_width: 0.5,
                interval: 1,
                g0: Some(100.0),
            },
            every: Every(1),
            dir: dir.to_path_buf(),
            thickness: 1.0,
            samples: Vec::new(),
            cells: Vec::new(),
            report: Rc::new(RefCell::new(None)),
        }
    }

    #[test]
    fn files_carry_the_rate_the_cells_and_survive_a_resume() {
        let dir = crate::atomic_file::test_dir("crack-surface");
        let mut o = observer(&dir);
        // Area 0, 1, 1, 3 with energies 0, 100, 150, 450: Γ = 100, none, 150.
        for (k, (a, e)) in [(0.0, 0.0), (1.0, 100.0), (1.0, 150.0), (3.0, 450.0)]
            .into_iter()
            .enumerate()
        {
            o.samples.push(Sample {
                time: k as f64,
                step: 10 * k as u64,
                area: a,
                dissipated: e,
            });
        }
        o.cells = vec![SurfaceCell {
            index: (1, -1),
            centre: (0.75, -0.25),
            height: 2.0,
            area: 3.0,
        }];
        Observer::<3>::finish(&mut o).unwrap();
        let area = std::fs::read_to_string(dir.join("crack_area.csv")).unwrap();
        assert_eq!(
            area,
            "time,step,crack_area,damage_dissipation,dissipation_rate,rate_over_g0\n\
             0,0,0,0,,\n1,10,1,100,100,1\n2,20,1,150,,\n3,30,3,450,150,1.5\n"
        );
        let cells = std::fs::read_to_string(dir.join("crack_surface.csv")).unwrap();
        assert_eq!(cells, "x,z,y,area\n0.75,-0.25,2,3\n");
        let vtu = std::fs::read_to_string(dir.join("crack_surface.vtu")).unwrap();
        // Corners (x, z) = (0.5..1, −0.5..0) at y = 2.
        assert!(vtu.contains(" 0.5 2 -0.5 1 2 -0.5 1 2 0 0.5 2 0 "), "{vtu}");
        assert!(vtu.contains("NumberOfPoints=\"4\" NumberOfCells=\"1\""));
        let report = o.report().borrow().clone().unwrap();
        assert_eq!(report.area, 3.0);
        assert!(report.to_string().contains("= 1.500 G0"), "{report}");
        // A restart at step 20 keeps three samples and writes the same rows for them.
        let resumed = observer(&dir).resume(20).unwrap();
        assert_eq!(resumed.samples, o.samples[..3]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
