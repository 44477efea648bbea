//! Field maps (`[output] maps`, `map_slice`): which files a run writes, and that the pictures
//! show the physics — a plate held at its left end and pulled at its right, quasi-statically,
//! has its displacement rise from the low to the high end of the colour map along x.

use peridyn::deck::LoadedDeck;
use peridyn::plot::damage_map::colormap;
use peridyn::run::{run, RunOptions};
use std::path::{Path, PathBuf};

const PULL: f64 = 2e-6;

/// An 8 mm × 2 mm plate (2D) or 8 × 2 × 2 mm bar (3D), spacing 0.25 mm, the 0.5 mm at x = 0
/// held and the 0.5 mm at x = 8 mm pulled by `PULL` along x in two quasi-static load steps.
fn stretched_bar(dim: usize, output: &str) -> LoadedDeck {
    let (head, max, lo, hi) = if dim == 2 {
        (
            "dimension = 2\nplane = \"stress\"\nthickness = 1e-3",
            "[8e-3, 2e-3]",
            ("rectangle", "[-1.0, -1.0]", "[0.5e-3, 1.0]"),
            ("rectangle", "[7.5e-3, -1.0]", "[1.0, 1.0]"),
        )
    } else {
        (
            "dimension = 3",
            "[8e-3, 2e-3, 2e-3]",
            ("box", "[-1.0, -1.0, -1.0]", "[0.5e-3, 1.0, 1.0]"),
            ("box", "[7.5e-3, -1.0, -1.0]", "[1.0, 1.0, 1.0]"),
        )
    };
    let (shape, min) = if dim == 2 {
        ("rectangle", "[0.0, 0.0]")
    } else {
        ("box", "[0.0, 0.0, 0.0]")
    };
    let text = format!(
        r#"
version = 2
{head}

[discretization]
type = "lattice"
shape = {{ type = "{shape}", min = {min}, max = {max} }}
spacing = 0.25e-3
horizon_ratio = 3.0

[material]
type = "pmb"
density = 1000.0
youngs_modulus = 1e9
critical_stretch = 1.0

[[node_sets]]
name = "held"
region = {{ type = "{}", min = {}, max = {} }}
[[node_sets]]
name = "pulled"
region = {{ type = "{}", min = {}, max = {} }}

[[boundary_conditions]]
set = "held"
kind = "displacement"
component = "x"
value = 0.0
[[boundary_conditions]]
set = "pulled"
kind = "displacement"
component = "x"
value = {PULL:e}
time = {{ type = "ramp", duration = 1.0 }}

[solver]
type = "quasi_static"
load_steps = 2

[output]
snapshots = 2
plots = false
{output}
"#,
        lo.0, lo.1, lo.2, hi.0, hi.1, hi.2
    );
    LoadedDeck::from_str(&text, Path::new("bar.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs the deck into a fresh folder named after `tag`.
fn run_into(ld: &LoadedDeck, tag: &str) -> PathBuf {
    let out = std::env::temp_dir().join(format!("peridyn-maps-{tag}-{}", std::process::id()));
    std::fs::remove_dir_all(&out).ok();
    let opts = RunOptions {
        out_dir: out.clone(),
        threads: None,
        quiet: true,
    };
    run(ld, &opts).unwrap_or_else(|e| panic!("{e}"));
    out
}

/// A decoded RGB image.
struct Image {
    width: usize,
    height: usize,
    rgb: Vec<u8>,
}

impl Image {
    fn read(path: &Path) -> Image {
        let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut reader = png::Decoder::new(file).read_info().unwrap();
        let mut rgb = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut rgb).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgb, "{}", path.display());
        rgb.truncate(info.buffer_size());
        Image {
            width: info.width as usize,
            height: info.height as usize,
            rgb,
        }
    }
    fn pixel(&self, x: usize, y: usize) -> [u8; 3] {
        let o = 3 * (y * self.width + x);
        [self.rgb[o], self.rgb[o + 1], self.rgb[o + 2]]
    }
    /// A colour-map colour, as opposed to the white background and the grey/black text, frame
    /// and ticks (viridis is never grey).
    fn coloured(&self, x: usize, y: usize) -> bool {
        let p = self.pixel(x, y);
        p.iter().max().unwrap() - p.iter().min().unwrap() > 30
    }
    /// The map values along the middle row of the plot, as colour-map positions in [0, 1].
    fn middle_row(&self) -> Vec<f64> {
        // A third of the way across lies inside the plot: its coloured rows are the plot's.
        let x = self.width / 3;
        let rows: Vec<usize> = (0..self.height).filter(|&y| self.coloured(x, y)).collect();
        assert!(rows.len() > 20, "no plot found in column {x}");
        let y = (rows[0] + rows[rows.len() - 1]) / 2;
        // The plot is the first coloured run of the row; the colour bar comes after a gap.
        let start = (0..self.width).find(|&x| self.coloured(x, y)).unwrap();
        let end = (start..self.width).find(|&x| !self.coloured(x, y)).unwrap();
        (start..end)
            .map(|x| colour_position(self.pixel(x, y)))
            .collect()
    }
}

/// Where on the colour map a colour lies (the nearest of 1001 samples).
fn colour_position(rgb: [u8; 3]) -> f64 {
    let distance =
        |c: [u8; 3]| -> i32 { (0..3).map(|k| (c[k] as i32 - rgb[k] as i32).pow(2)).sum() };
    let k = (0..=1000)
        .min_by_key(|&k| distance(colormap(k as f64 / 1000.0)))
        .unwrap();
    k as f64 / 1000.0
}

fn pngs_in(dir: &Path, prefix: &str) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.starts_with(prefix) && n.ends_with(".png"))
        .collect();
    names.sort();
    names
}

/// The latest numbered map of each field is the `<field>.png` copy.
fn assert_numbered_maps(out: &Path, fields: &[&str], steps: &[&str]) {
    for field in fields {
        let numbered = pngs_in(&out.join("images"), &format!("{field}_step_"));
        let expected: Vec<String> = steps
            .iter()
            .map(|s| format!("{field}_step_{s}.png"))
            .collect();
        assert_eq!(numbered, expected, "{field}");
        let latest = std::fs::read(out.join("images").join(numbered.last().unwrap())).unwrap();
        assert_eq!(
            latest,
            std::fs::read(out.join(format!("{field}.png"))).unwrap()
        );
    }
}

#[test]
fn a_2d_run_maps_each_chosen_field_and_the_maps_show_the_stretch() {
    let ld = stretched_bar(2, r#"maps = ["damage", "strain_energy", "displacement"]"#);
    let out = run_into(&ld, "2d");
    let steps = ["00000000", "00000001", "00000002"];
    assert_numbered_maps(&out, &["damage", "strain_energy", "displacement"], &steps);

    // Displacement: 0 at the held end (low end of the map), PULL at the pulled end (top,
    // the range being 0..max), rising in between.
    let u = Image::read(&out.join("displacement.png")).middle_row();
    let (first, last) = (u[1], u[u.len() - 2]);
    println!(
        "displacement along x: {first} … {} … {last} ({} px)",
        u[u.len() / 2],
        u.len()
    );
    assert!(first < 0.05 && last > 0.95, "{first} {last}");
    let quarter = |k: usize| u[k * (u.len() - 1) / 4];
    assert!(quarter(1) < quarter(2) && quarter(2) < quarter(3));
    assert!(
        (quarter(2) - 0.5).abs() < 0.1,
        "the middle moves half the pull"
    );

    // Strain energy: the stretched middle near the top of its range; the held end, whose bonds
    // are mostly unstretched, well below it.
    let w = Image::read(&out.join("strain_energy.png")).middle_row();
    let (end, middle) = (w[1], w[w.len() / 2]);
    println!("strain energy density along x: held end {end}, middle {middle}");
    assert!(middle > 0.6 && end < middle - 0.3, "{end} {middle}");

    // No bond breaks: the damage map is uniformly at its low end.
    let d = Image::read(&out.join("damage.png")).middle_row();
    assert!(d.iter().all(|&t| t == 0.0));
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn the_default_is_todays_damage_map_and_png_false_draws_nothing() {
    let out = run_into(&stretched_bar(2, ""), "default");
    assert_eq!(pngs_in(&out, ""), ["damage.png"]);
    assert_numbered_maps(&out, &["damage"], &["00000000", "00000001", "00000002"]);
    std::fs::remove_dir_all(&out).ok();

    let out = run_into(
        &stretched_bar(2, "png = false\nmaps = [\"displacement\"]"),
        "off",
    );
    assert!(pngs_in(&out, "").is_empty());
    assert!(!out.join("images").exists());
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn a_3d_run_maps_a_slice() {
    // The default plane: z = 1 mm, the bar's mid-plane, a picture of 8 mm × 2 mm in x and y.
    let ld = stretched_bar(3, r#"maps = ["displacement", "strain_energy"]"#);
    let out = run_into(&ld, "3d");
    assert_numbered_maps(
        &out,
        &["displacement", "strain_energy"],
        &["00000000", "00000001", "00000002"],
    );
    assert!(!out.join("damage.png").exists());
    let img = Image::read(&out.join("displacement.png"));
    let u = img.middle_row();
    let (first, last) = (u[1], u[u.len() - 2]);
    println!("3D slice, displacement along x: {first} … {last}");
    assert!(first < 0.05 && last > 0.95, "{first} {last}");
    assert!(img.width > img.height, "{} × {} px", img.width, img.height);
    std::fs::remove_dir_all(&out).ok();

    // A plane across the bar (normal x, at its middle): every node of the slice has moved
    // about half the pull, so the map is one colour across its width, halfway up the range
    // (the colour range is the whole bar's).
    let ld = stretched_bar(
        3,
        "maps = [\"displacement\"]\nmap_slice = { axis = \"x\", at = 4e-3 }",
    );
    let out = run_into(&ld, "3d-across");
    let u = Image::read(&out.join("displacement.png")).middle_row();
    println!(
        "3D slice across x = 4 mm, displacement along y: {:?}",
        (u[1], u[u.len() - 2])
    );
    assert!(
        u[1..u.len() - 1].iter().all(|&t| (t - 0.5).abs() < 0.1),
        "{u:?}"
    );
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn an_unknown_map_is_refused_naming_the_key_and_the_choices() {
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/decks/bad/output_maps_unknown_field.toml"),
    )
    .unwrap();
    let text = text.replace("[\"damage\", \"stress\"]", "[\"stress\"]");
    let err = LoadedDeck::from_str(&text, Path::new("bad.toml"))
        .unwrap_err()
        .to_string();
    println!("{err}");
    assert!(err.starts_with("bad.toml:"), "{err}");
    assert!(err.contains("output.maps"), "{err}");
    for choice in ["`stress`", "`damage`", "`strain_energy`", "`displacement`"] {
        assert!(err.contains(choice), "{err}");
    }
}
