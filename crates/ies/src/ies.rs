//! IES LM-63 reader (1986, 1991, 1995, 2002, 2019).

use crate::model::{Format, Keyword, PhotometricType, Tilt, TiltData, Units, Warning};
use crate::photometry::Parts;
use crate::text::{Tokens, shorten};
use crate::{IesError, Limits, ParseOptions, Photometry};

/// The version named by the first line, or `None` for an LM-63-1986 file (no version line).
fn version(first: &str) -> Option<Format> {
    let up = first.trim().to_ascii_uppercase();
    if up.starts_with("IESNA91") {
        return Some(Format::Lm63_1991);
    }
    if !(up.starts_with("IESNA") || up.starts_with("IES:")) {
        return None;
    }
    let year: Option<u32> = up
        .split("LM-63-")
        .nth(1)
        .and_then(|rest| rest.get(..4))
        .and_then(|y| y.parse().ok());
    Some(match year {
        Some(y) if y < 1995 => Format::Lm63_1991,
        Some(y) if y < 2002 => Format::Lm63_1995,
        Some(y) if y < 2019 => Format::Lm63_2002,
        Some(_) => Format::Lm63_2019,
        // "IESNA:..." with no readable year: the most common modern layout.
        None => Format::Lm63_2002,
    })
}

/// Reads an LM-63 file already split into lines.
pub(crate) fn parse(lines: &[&str], options: &ParseOptions) -> Result<Photometry, IesError> {
    let limits = &options.limits;
    let mut warnings = Vec::new();
    let first_content = lines.iter().position(|l| !l.trim().is_empty()).unwrap_or(0);
    let format = version(lines.get(first_content).copied().unwrap_or(""));
    let header_start = if format.is_some() {
        first_content + 1
    } else {
        0
    };
    let format = format.unwrap_or(Format::Lm63_1986);

    // Keyword block up to the TILT line.
    let mut keywords: Vec<Keyword> = Vec::new();
    let mut tilt_line = None;
    for (idx, raw) in lines.iter().enumerate().skip(header_start) {
        let line_no = idx + 1;
        let l = raw.trim();
        if l.to_ascii_uppercase().starts_with("TILT") {
            tilt_line = Some(idx);
            break;
        }
        limits.check(
            line_no,
            "number of header lines",
            idx - header_start + 1,
            limits.max_header_lines,
        )?;
        if l.is_empty() {
            continue;
        }
        if format == Format::Lm63_1986 {
            keywords.push(Keyword {
                key: String::new(),
                value: l.to_owned(),
            });
            continue;
        }
        match l.strip_prefix('[').and_then(|r| r.split_once(']')) {
            Some((key, value)) if !key.is_empty() => {
                let value = value.trim();
                if key.eq_ignore_ascii_case("MORE") {
                    if let Some(prev) = keywords.last_mut() {
                        prev.value.push('\n');
                        prev.value.push_str(value);
                        continue;
                    }
                    warnings.push(Warning {
                        line: line_no,
                        message: "[MORE] with no keyword before it".into(),
                    });
                }
                keywords.push(Keyword {
                    key: key.to_owned(),
                    value: value.to_owned(),
                });
            }
            _ => {
                warnings.push(Warning {
                    line: line_no,
                    message: format!("line without a [KEYWORD] kept as a label: `{}`", shorten(l)),
                });
                keywords.push(Keyword {
                    key: String::new(),
                    value: l.to_owned(),
                });
            }
        }
    }
    let tilt_idx = tilt_line.ok_or(IesError::MissingTilt)?;
    let tilt_text = lines[tilt_idx].trim();
    let tilt_value = tilt_text
        .split_once('=')
        .map(|(_, v)| v.trim())
        .ok_or_else(|| IesError::Syntax {
            line: tilt_idx + 1,
            expected: "TILT=NONE, TILT=INCLUDE or TILT=<file>".into(),
            found: shorten(tilt_text),
        })?;
    let rest = &lines[tilt_idx + 1..];
    let mut tokens = Tokens::new(rest, tilt_idx + 2);
    let tilt = match tilt_value.to_ascii_uppercase().as_str() {
        "NONE" => Tilt::None,
        "INCLUDE" => Tilt::Include(tilt_block(&mut tokens, limits)?),
        _ => {
            let name = tilt_value.to_owned();
            let unresolved = || IesError::TiltFileUnresolved {
                line: tilt_idx + 1,
                name: name.clone(),
            };
            let resolver = options.tilt_resolver.ok_or_else(unresolved)?;
            let bytes = resolver(&name).ok_or_else(unresolved)?;
            let data = parse_tilt_file(&bytes, limits).map_err(|e| IesError::TiltFile {
                name: name.clone(),
                source: Box::new(e),
            })?;
            Tilt::File { name, data }
        }
    };

    let t = &mut tokens;
    let (lamps, _) = t.integer("number of lamps", 0, i64::from(u32::MAX))?;
    let (lumens, l_lumens) = t.number("lumens per lamp")?;
    let lumens_per_lamp = if lumens == -1.0 {
        None
    } else if lumens >= 0.0 {
        Some(lumens)
    } else {
        return Err(IesError::OutOfRange {
            line: l_lumens,
            what: "lumens per lamp".into(),
            value: lumens,
            expected: "≥ 0, or -1 for absolute photometry".into(),
        });
    };
    let (candela_multiplier, _) = t.number("candela multiplier")?;
    let (nv, l_nv) = t.integer("number of vertical angles", 1, i64::from(u32::MAX))?;
    limits.check(
        l_nv,
        "number of vertical angles",
        nv as usize,
        limits.max_angles,
    )?;
    let (nh, l_nh) = t.integer("number of horizontal angles", 1, i64::from(u32::MAX))?;
    limits.check(
        l_nh,
        "number of horizontal angles",
        nh as usize,
        limits.max_angles,
    )?;
    let (nv, nh) = (nv as usize, nh as usize);
    let n_values = nv.saturating_mul(nh);
    limits.check(
        l_nh,
        "number of candela values",
        n_values,
        limits.max_values,
    )?;
    let (ptype, _) = t.integer("photometric type (1 = C, 2 = B, 3 = A)", 1, 3)?;
    let photometric_type = match ptype {
        1 => PhotometricType::C,
        2 => PhotometricType::B,
        _ => PhotometricType::A,
    };
    let (units, _) = t.integer("units type (1 = feet, 2 = metres)", 1, 2)?;
    let units = if units == 1 {
        Units::Feet
    } else {
        Units::Meters
    };
    let (width, _) = t.number("luminous opening width")?;
    let (length, _) = t.number("luminous opening length")?;
    let (height, _) = t.number("luminous opening height")?;
    let (ballast_factor, _) = t.number("ballast factor")?;
    let (ballast_lamp_factor, _) = t.number(if format == Format::Lm63_2019 {
        "file generation type"
    } else {
        "ballast-lamp photometric factor"
    })?;
    let (input_watts, _) = t.number("input watts")?;
    let (vertical_angles, l_v) = t.numbers(nv, "vertical angle")?;
    let (horizontal_angles, l_h) = t.numbers(nh, "horizontal angle")?;
    let (candela, l_c) = t.numbers(n_values, "candela value")?;
    if let Some((tok, line)) = t.next_token() {
        warnings.push(Warning {
            line,
            message: format!(
                "trailing data after the last candela value, ignored: `{}`",
                shorten(tok)
            ),
        });
    }
    Photometry::assemble(Parts {
        format,
        keywords,
        tilt,
        lamp_count: lamps as u32,
        lumens_per_lamp,
        candela_multiplier,
        photometric_type,
        units,
        dimensions: [width, length, height],
        ballast_factor,
        ballast_lamp_factor,
        input_watts,
        vertical_angles,
        horizontal_angles,
        candela,
        ldt: None,
        warnings,
        lines: [l_v, l_h, l_c],
    })
}

/// Reads the tilt block: geometry, pair count, angles, factors.
fn tilt_block(t: &mut Tokens, limits: &Limits) -> Result<TiltData, IesError> {
    let (geometry, _) = t.integer("lamp-to-luminaire geometry (1, 2 or 3)", 1, 3)?;
    let (n, line) = t.integer("number of tilt angle/factor pairs", 1, i64::from(u32::MAX))?;
    let n = n as usize;
    limits.check(
        line,
        "number of tilt angle/factor pairs",
        n,
        limits.max_tilt_pairs,
    )?;
    let mut angles = Vec::with_capacity(n);
    for _ in 0..n {
        let (a, line) = t.number("tilt angle")?;
        if let Some(&prev) = angles.last()
            && a <= prev
        {
            return Err(IesError::NotIncreasing {
                line,
                what: "tilt angles".into(),
                previous: prev,
                next: a,
            });
        }
        if !(-360.0..=360.0).contains(&a) {
            return Err(IesError::OutOfRange {
                line,
                what: "tilt angle".into(),
                value: a,
                expected: "from -360 to 360 degrees".into(),
            });
        }
        angles.push(a);
    }
    let mut factors = Vec::with_capacity(n);
    for _ in 0..n {
        let (f, line) = t.number("tilt multiplying factor")?;
        if !(0.0..=1000.0).contains(&f) {
            return Err(IesError::OutOfRange {
                line,
                what: "tilt multiplying factor".into(),
                value: f,
                expected: "from 0 to 1000".into(),
            });
        }
        factors.push(f);
    }
    Ok(TiltData {
        lamp_geometry: geometry as u8,
        angles,
        factors,
    })
}

/// A separate tilt file holds just the tilt block.
fn parse_tilt_file(bytes: &[u8], limits: &Limits) -> Result<TiltData, IesError> {
    if bytes.len() > limits.max_bytes {
        return Err(IesError::TooLarge {
            size: bytes.len(),
            limit: limits.max_bytes,
        });
    }
    let text = crate::text::decode(bytes);
    let lines = crate::text::lines(&text);
    tilt_block(&mut Tokens::new(&lines, 1), limits)
}
