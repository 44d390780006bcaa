//! `cargo xtask ies FILE [--json] [--at V H]`: what a lighting engineer checks first in a
//! photometric file.

use luxbake_ies::{Photometry, Tilt};
use serde_json::json;
use std::path::PathBuf;

/// Arguments of `cargo xtask ies`.
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
    if let Some(at) = &args.at {
        let (v, h) = (at[0], at[1]);
        let cd = lamp.intensity_at(v, h);
        if args.json {
            println!("{}", json!({ "candela": cd }));
        } else {
            println!("{cd:.4} cd at vertical {v}°, horizontal {h}°");
        }
        return Ok(());
    }
    let flux = lamp.luminous_flux();
    let (max_cd, max_dir) = lamp.max_intensity();
    let opening = lamp.luminous_opening();
    if args.json {
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
        let out = json!({
            "file": args.file.display().to_string(),
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
            "lumens_integrated": flux,
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
            },
            "keywords": keywords,
            "warnings": warnings,
        });
        println!("{out}");
        return Ok(());
    }
    let range = |a: &[f64]| match (a.first(), a.last()) {
        (Some(f), Some(l)) => format!("{} angles, {f}° … {l}°", a.len()),
        _ => "none".to_owned(),
    };
    println!("file              {}", args.file.display());
    println!("format            {}", lamp.format().name());
    println!("photometric type  {}", lamp.photometric_type().name());
    println!("vertical          {}", range(lamp.vertical_angles()));
    println!("horizontal        {}", range(lamp.horizontal_angles()));
    println!("symmetry          {}", lamp.symmetry().name());
    println!("tilt              {}", tilt_name(lamp.tilt()));
    println!(
        "lamps             {} × {}",
        lamp.lamp_count(),
        lamp.lumens_per_lamp()
            .map_or("absolute photometry".to_owned(), |l| format!("{l} lm"))
    );
    println!("candela mult.     {}", lamp.candela_multiplier());
    println!("ballast factor    {}", lamp.ballast_factor());
    println!("input watts       {}", lamp.input_watts());
    println!(
        "opening           {:?}, {:.3} × {:.3} × {:.3} m (width × length × height)",
        opening.shape, opening.width, opening.length, opening.height
    );
    match lamp.lumens_header() {
        Some(h) => println!(
            "lumens            {flux:.1} lm integrated, {h:.1} lm header (ratio {:.4})",
            if h > 0.0 { flux / h } else { f64::NAN }
        ),
        None => println!("lumens            {flux:.1} lm integrated (absolute photometry)"),
    }
    println!(
        "max intensity     {max_cd:.2} cd toward ({:.4}, {:.4}, {:.4})",
        max_dir[0], max_dir[1], max_dir[2]
    );
    if lamp.input_watts() > 0.0 {
        println!("efficacy          {:.1} lm/W", flux / lamp.input_watts());
    }
    for k in lamp.keywords() {
        let key = if k.key.is_empty() { "label" } else { &k.key };
        println!("[{key}] {}", k.value.replace('\n', " / "));
    }
    for w in lamp.warnings() {
        println!("warning: line {}: {}", w.line, w.message);
    }
    Ok(())
}

fn tilt_name(t: &Tilt) -> String {
    match t {
        Tilt::None => "NONE".to_owned(),
        Tilt::Include(d) => format!("INCLUDE ({} angles)", d.angles.len()),
        Tilt::File { name, data } => format!("file {name} ({} angles)", data.angles.len()),
    }
}
