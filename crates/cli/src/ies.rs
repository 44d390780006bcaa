//! `luxbake ies FILE [--json] [--at V H]`: what a lighting engineer checks first in a
//! photometric file.

use luxbake_ies::{Photometry, Tilt};
use serde_json::json;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Arguments of `luxbake ies` (and `cargo xtask ies`).
#[derive(clap::Args)]
pub struct Args {
    /// The IES (.ies) or EULUMDAT (.ldt) file.
    file: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
    /// Print only the interpolated candela at vertical angle V, horizontal angle H (degrees, in
    /// the file's own angle convention).
    #[arg(long, num_args = 2, value_names = ["V", "H"], allow_negative_numbers = true)]
    at: Option<Vec<f64>>,
}

/// Runs the inspector; the error is a message for stderr.
pub fn run(args: &Args) -> Result<(), String> {
    let bytes = std::fs::read(&args.file)
        .map_err(|e| format!("cannot read {}: {e}", args.file.display()))?;
    let lamp = Photometry::parse(&bytes).map_err(|e| format!("{}: {e}", args.file.display()))?;
    let mut o = String::new();
    if let Some(at) = &args.at {
        let (v, h) = (at[0], at[1]);
        let cd = lamp.intensity_at(v, h);
        if args.json {
            let _ = writeln!(o, "{}", json!({ "candela": cd }));
        } else {
            let _ = writeln!(o, "{cd:.4} cd at vertical {v}°, horizontal {h}°");
        }
        emit(&o);
        return Ok(());
    }
    if args.json {
        let _ = writeln!(o, "{}", report_json(&args.file, &lamp));
        emit(&o);
        return Ok(());
    }
    let flux = lamp.luminous_flux();
    let (max_cd, max_dir) = lamp.max_intensity();
    let opening = lamp.luminous_opening();
    let range = |a: &[f64]| match (a.first(), a.last()) {
        (Some(f), Some(l)) => format!("{} angles, {f}° … {l}°", a.len()),
        _ => "none".to_owned(),
    };
    let _ = writeln!(o, "file              {}", args.file.display());
    let _ = writeln!(o, "format            {}", lamp.format().name());
    let _ = writeln!(o, "photometric type  {}", lamp.photometric_type().name());
    let _ = writeln!(o, "vertical          {}", range(lamp.vertical_angles()));
    let _ = writeln!(o, "horizontal        {}", range(lamp.horizontal_angles()));
    let _ = writeln!(o, "symmetry          {}", lamp.symmetry().name());
    let _ = writeln!(o, "tilt              {}", tilt_name(lamp.tilt()));
    let _ = writeln!(
        o,
        "lamps             {} × {}",
        lamp.lamp_count(),
        lamp.lumens_per_lamp()
            .map_or("absolute photometry".to_owned(), |l| format!("{l} lm"))
    );
    let _ = writeln!(o, "candela mult.     {}", lamp.candela_multiplier());
    let _ = writeln!(o, "ballast factor    {}", lamp.ballast_factor());
    let _ = writeln!(o, "input watts       {}", lamp.input_watts());
    let _ = writeln!(
        o,
        "opening           {:?}, {:.3} × {:.3} × {:.3} m (width × length × height)",
        opening.shape, opening.width, opening.length, opening.height
    );
    match lamp.emitter() {
        Some(e) => {
            let axis = ["X", "Y", "Z"][usize::from(e.axis.min(2))];
            let _ = writeln!(
                o,
                "emitter           {}, axis {axis}, half {:.4} × {:.4} × {:.4} m (u × v × w), \
                 emitting {}, area {:.5} m²",
                e.kind.name(),
                e.half[0],
                e.half[1],
                e.half[2],
                e.part_names().join(" + "),
                e.area()
            );
            let _ = writeln!(
                o,
                "point model       within 1 % beyond {:.3} m",
                e.point_model_distance(0.01)
            );
        }
        None => {
            let _ = writeln!(o, "emitter           none (point)");
        }
    }
    let _ = match lamp.lumens_header() {
        Some(h) => writeln!(
            o,
            "lumens            {flux:.1} lm integrated, {h:.1} lm header (ratio {:.4})",
            if h > 0.0 { flux / h } else { f64::NAN }
        ),
        None => writeln!(
            o,
            "lumens            {flux:.1} lm integrated (absolute photometry)"
        ),
    };
    let _ = writeln!(
        o,
        "max intensity     {max_cd:.2} cd toward ({:.4}, {:.4}, {:.4})",
        max_dir[0], max_dir[1], max_dir[2]
    );
    if lamp.input_watts() > 0.0 {
        let _ = writeln!(o, "efficacy          {:.1} lm/W", flux / lamp.input_watts());
    }
    for k in lamp.keywords() {
        let key = if k.key.is_empty() { "label" } else { &k.key };
        let _ = writeln!(o, "[{key}] {}", k.value.replace('\n', " / "));
    }
    for w in lamp.warnings() {
        let _ = writeln!(o, "warning: line {}: {}", w.line, w.message);
    }
    emit(&o);
    Ok(())
}

/// Writes the report to stdout; a closed pipe (`| head`) is not an error worth a panic.
fn emit(text: &str) {
    use std::io::Write;
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
}

/// The `--json` report: one object with the fields a lighting engineer checks.
fn report_json(file: &Path, lamp: &Photometry) -> serde_json::Value {
    let (max_cd, max_dir) = lamp.max_intensity();
    let opening = lamp.luminous_opening();
    let emitter = lamp.emitter().map(|e| {
        let axis = ["x", "y", "z"][usize::from(e.axis.min(2))];
        json!({
            "solid": e.kind.name(),
            "axis": axis,
            "half_m": e.half,
            "faces": e.part_names(),
            "area_m2": e.area(),
            "point_model_1pct_m": e.point_model_distance(0.01),
        })
    });
    let keywords: Vec<_> = lamp
        .keywords()
        .iter()
        .map(|k| json!({ "key": k.key, "value": k.value }))
        .collect();
    let warnings: Vec<_> = lamp
        .warnings()
        .iter()
        .map(|w| json!({ "line": w.line, "message": w.message }))
        .collect();
    json!({
        "file": file.display().to_string(),
        "format": lamp.format().name(),
        "photometric_type": lamp.photometric_type().name(),
        "vertical_angles": lamp.vertical_angles().len(),
        "horizontal_angles": lamp.horizontal_angles().len(),
        "vertical_range": [lamp.vertical_angles().first(), lamp.vertical_angles().last()],
        "horizontal_range": [lamp.horizontal_angles().first(), lamp.horizontal_angles().last()],
        "symmetry": lamp.symmetry().name(),
        "candela_multiplier": lamp.candela_multiplier(),
        "ballast_factor": lamp.ballast_factor(),
        "lamp_count": lamp.lamp_count(),
        "lumens_per_lamp": lamp.lumens_per_lamp(),
        "lumens_header": lamp.lumens_header(),
        "lumens_integrated": lamp.luminous_flux(),
        "flux_ratio": lamp.flux_ratio(),
        "max_candela": max_cd,
        "max_direction": max_dir,
        "input_watts": lamp.input_watts(),
        "tilt": tilt_name(lamp.tilt()),
        "luminous_opening": {
            "shape": format!("{:?}", opening.shape),
            "width_m": opening.width,
            "length_m": opening.length,
            "height_m": opening.height,
            "emitter": emitter,
        },
        "keywords": keywords,
        "warnings": warnings,
    })
}

fn tilt_name(t: &Tilt) -> String {
    match t {
        Tilt::None => "NONE".to_owned(),
        Tilt::Include(d) => format!("INCLUDE ({} angles)", d.angles.len()),
        Tilt::File { name, data } => format!("file {name} ({} angles)", data.angles.len()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_report_of_the_bundled_lamp() {
        let file =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../scene/lamps/luxbake_downlight.ies");
        let lamp = Photometry::parse(&std::fs::read(&file).unwrap()).unwrap();
        let j = report_json(&file, &lamp);
        assert_eq!(j["format"], "LM-63-2002");
        assert_eq!(j["photometric_type"], "C");
        assert_eq!(j["vertical_angles"], 37);
        assert_eq!(j["horizontal_angles"], 25);
        assert_eq!(j["symmetry"], "none (0-360)");
        assert_eq!(j["candela_multiplier"], 1.0);
        let header = j["lumens_header"].as_f64().unwrap();
        let integrated = j["lumens_integrated"].as_f64().unwrap();
        assert!((integrated / header - 1.0).abs() < 1e-4);
        assert!(j["max_candela"].as_f64().unwrap() > 1000.0);
        let o = &j["luminous_opening"];
        assert!(o["shape"].is_string() && o["width_m"].is_number());
        assert!(o["length_m"].is_number() && o["height_m"].is_number());
    }

    #[test]
    fn json_report_shows_the_emitter() {
        // A 0.3 m × 0.6 m flat downlight: a box with only its bottom lit.
        let text = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 2 1 1 2 0.3 0.6 0\n1 1 0\n0 90\n0\n10 0\n";
        let lamp = Photometry::parse(text.as_bytes()).unwrap();
        let e = &report_json(Path::new("x.ies"), &lamp)["luminous_opening"]["emitter"];
        assert_eq!(e["solid"], "box");
        assert_eq!(e["axis"], "z");
        assert_eq!(e["faces"], json!(["bottom"]));
        assert!((e["area_m2"].as_f64().unwrap() - 0.18).abs() < 1e-12);
        assert_eq!(e["half_m"], json!([0.3, 0.15, 0.0]));
        assert!(e["point_model_1pct_m"].as_f64().unwrap() > 0.0);
        // A point opening has none.
        let point = text.replace("0.3 0.6 0", "0 0 0");
        let lamp = Photometry::parse(point.as_bytes()).unwrap();
        assert!(report_json(Path::new("x.ies"), &lamp)["luminous_opening"]["emitter"].is_null());
    }

    #[test]
    fn absolute_photometry_has_null_header_lumens() {
        let text = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n10 0\n";
        let lamp = Photometry::parse(text.as_bytes()).unwrap();
        let j = report_json(Path::new("x.ies"), &lamp);
        assert!(j["lumens_header"].is_null());
    }

    #[test]
    fn errors_are_messages() {
        let args = Args {
            file: PathBuf::from("/nonexistent.ies"),
            json: false,
            at: None,
        };
        assert!(run(&args).unwrap_err().contains("cannot read"));
    }
}
