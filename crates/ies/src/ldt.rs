//! EULUMDAT (`.ldt`) reader.
//!
//! Layout (one field per line): company; Ityp; Isym; Mc; Dc; Ng; Dg; report number; luminaire
//! name; luminaire number; file name; date/user; luminaire length, width, height (mm); luminous
//! area length, width (mm); luminous area height at C0, C90, C180, C270 (mm); DFF (%); LORL (%);
//! conversion factor; measurement tilt; n lamp sets; then n lines each of lamp count, lamp type,
//! flux (lm), colour, CRI, watts; 10 direct ratios; Mc C angles; Ng γ angles; intensities in
//! cd/klm, Ng per stored C plane. Stored planes by Isym: 0 all Mc; 1 one; 2 C0–C180 (Mc/2+1);
//! 3 C90–C270 (Mc/2+1); 4 C0–C90 (Mc/4+1).
//!
//! The luminous area becomes LM-63 opening dimensions: width = its width (along C90–C270),
//! length = its length (along C0–C180), height = the largest of its four heights; width 0 is
//! a circle of diameter length (see the [`opening`](crate::opening) module docs).
//!
//! Several lamp sets are one luminaire with all of them fitted: the intensities are per
//! 1000 lm of the total flux of every set, and the header's lamps, lumens and watts are the
//! sums over the sets. A negative lamp count (absolute photometry) must be negative in every
//! set.

use crate::model::{Format, Keyword, LampSet, LdtInfo, PhotometricType, Tilt, Units, Warning};
use crate::photometry::Parts;
use crate::text::{Tokens, integer_in, parse_number, shorten};
use crate::{IesError, Limits, Photometry};

/// Reads header lines one field per line.
struct Fields<'a> {
    lines: &'a [&'a str],
    next: usize,
}

impl<'a> Fields<'a> {
    fn text(&mut self, what: &str) -> Result<(&'a str, usize), IesError> {
        let Some(l) = self.lines.get(self.next) else {
            return Err(IesError::UnexpectedEof {
                line: self.lines.len(),
                expected: what.to_owned(),
            });
        };
        self.next += 1;
        Ok((l.trim(), self.next))
    }

    fn number(&mut self, what: &str) -> Result<(f64, usize), IesError> {
        let (s, line) = self.text(what)?;
        // An empty numeric field counts as 0, as EULUMDAT writers leave optional fields blank.
        if s.is_empty() {
            return Ok((0.0, line));
        }
        let v = parse_number(s, true).ok_or_else(|| IesError::Syntax {
            line,
            expected: format!("{what} (a finite number)"),
            found: shorten(s),
        })?;
        Ok((v, line))
    }

    /// `count` values, one per lamp set, each read by `read`.
    fn per_set<T>(
        &mut self,
        count: usize,
        mut read: impl FnMut(&mut Self) -> Result<T, IesError>,
    ) -> Result<Vec<T>, IesError> {
        (0..count).map(|_| read(self)).collect()
    }

    fn integer(&mut self, what: &str, min: i64, max: i64) -> Result<(i64, usize), IesError> {
        let (v, line) = self.number(what)?;
        integer_in(v, line, what, min, max).map(|i| (i, line))
    }
}

pub(crate) fn parse(lines: &[&str], limits: &Limits) -> Result<Photometry, IesError> {
    let mut f = Fields { lines, next: 0 };
    let (company, _) = f.text("company identification")?;
    let (ityp, _) = f.integer("type indicator Ityp", 0, 3)?;
    let (isym, l_isym) = f.integer("symmetry indicator Isym", 0, 4)?;
    let (mc, l_mc) = f.integer("number of C planes Mc", 1, i64::from(u32::MAX))?;
    limits.check(
        l_mc,
        "number of C planes Mc",
        mc as usize,
        limits.max_angles,
    )?;
    let (dc, _) = f.number("distance between C planes Dc")?;
    let (ng, l_ng) = f.integer(
        "number of intensities per C plane Ng",
        1,
        i64::from(u32::MAX),
    )?;
    limits.check(
        l_ng,
        "number of intensities per C plane Ng",
        ng as usize,
        limits.max_angles,
    )?;
    let (dg, _) = f.number("distance between intensities Dg")?;
    let (mc, ng) = (mc as usize, ng as usize);
    let mut texts = [""; 5];
    for (slot, what) in texts.iter_mut().zip([
        "measurement report number",
        "luminaire name",
        "luminaire number",
        "file name",
        "date/user",
    ]) {
        *slot = f.text(what)?.0;
    }
    let mut nums = [0.0; 13];
    for (slot, what) in nums.iter_mut().zip([
        "luminaire length/diameter",
        "luminaire width",
        "luminaire height",
        "luminous area length/diameter",
        "luminous area width",
        "luminous area height C0",
        "luminous area height C90",
        "luminous area height C180",
        "luminous area height C270",
        "downward flux fraction",
        "light output ratio",
        "conversion factor",
        "tilt during measurement",
    ]) {
        *slot = f.number(what)?.0;
    }
    let (n_sets, l_sets) = f.integer("number of lamp sets", 1, i64::from(u32::MAX))?;
    limits.check(
        l_sets,
        "number of lamp sets",
        n_sets as usize,
        limits.max_lamp_sets,
    )?;
    let n_sets = n_sets as usize;
    let mut counts = Vec::with_capacity(n_sets);
    for k in 0..n_sets {
        let (count, line) = f.integer("number of lamps", -1_000_000, 1_000_000)?;
        // A negative count means absolute photometry, for the whole luminaire: every set
        // must say the same.
        if k > 0 && (count < 0) != (counts[0] < 0) {
            return Err(IesError::OutOfRange {
                line,
                what: format!("number of lamps of lamp set {}", k + 1),
                value: count as f64,
                expected: format!(
                    "the sign of lamp set 1 ({}): negative counts (absolute photometry) \
                     in every set or in none",
                    counts[0]
                ),
            });
        }
        counts.push(count);
    }
    let types = f.per_set(n_sets, |f| Ok(f.text("type of lamps")?.0.to_owned()))?;
    let fluxes = f.per_set(n_sets, |f| {
        let (flux, line) = f.number("total luminous flux of lamps")?;
        if flux < 0.0 {
            return Err(IesError::OutOfRange {
                line,
                what: "lamp flux".into(),
                value: flux,
                expected: "≥ 0 lumens".into(),
            });
        }
        Ok(flux)
    })?;
    let colors = f.per_set(n_sets, |f| Ok(f.text("colour appearance")?.0.to_owned()))?;
    let cris = f.per_set(n_sets, |f| Ok(f.text("colour rendering")?.0.to_owned()))?;
    let watts = f.per_set(n_sets, |f| Ok(f.number("wattage including ballast")?.0))?;
    let mut direct_ratios = [0.0; 10];
    for dr in &mut direct_ratios {
        *dr = f.number("direct ratio")?.0;
    }
    let lamp_sets: Vec<LampSet> = (0..n_sets)
        .map(|i| LampSet {
            count: counts[i],
            lamp_type: types[i].clone(),
            flux: fluxes[i],
            color: colors[i].clone(),
            cri: cris[i].clone(),
            watts: watts[i],
        })
        .collect();

    // Angles and intensities: read as a token stream (tolerates several values per line).
    let data_lines = &lines[f.next.min(lines.len())..];
    let mut t = Tokens::with_decimal_comma(data_lines, f.next + 1);
    let (c_angles, l_c) = t.numbers(mc, "C angle")?;
    let (gammas, l_g) = t.numbers(ng, "γ angle")?;
    let unsupported = |detail: String| IesError::UnsupportedAngles {
        line: l_isym,
        detail,
    };
    // Stored planes: index range into c_angles.
    let (start, count) = match isym {
        0 => (0, mc),
        1 => (0, 1),
        2 | 3 if mc % 2 == 0 => (if isym == 2 { 0 } else { mc / 4 }, mc / 2 + 1),
        4 if mc % 4 == 0 => (0, mc / 4 + 1),
        _ => {
            return Err(unsupported(format!(
                "Isym {isym} needs Mc divisible by {}, Mc is {mc}",
                if isym == 4 { 4 } else { 2 }
            )));
        }
    };
    if isym == 3 && mc % 4 != 0 {
        return Err(unsupported(format!(
            "Isym 3 needs Mc divisible by 4, Mc is {mc}"
        )));
    }
    let horizontal: Vec<f64> = if isym == 1 {
        vec![0.0]
    } else {
        let slice = c_angles.get(start..start + count).ok_or_else(|| {
            unsupported(format!(
                "Mc = {mc} C angles cannot hold {count} planes from index {start}"
            ))
        })?;
        slice.to_vec()
    };
    let expect = |ok: bool, what: &str| -> Result<(), IesError> {
        if ok {
            Ok(())
        } else {
            Err(IesError::UnsupportedAngles {
                line: l_c,
                detail: format!(
                    "Isym {isym}: the stored C planes must run {what}, got {horizontal:?}"
                ),
            })
        }
    };
    let first = horizontal[0];
    let last = horizontal[horizontal.len() - 1];
    let near = |a: f64, b: f64| (a - b).abs() < 1e-6;
    match isym {
        0 => expect(
            near(first, 0.0) && (mc == 1 || last > 180.0) && last < 360.0,
            "from C0 to below C360",
        )?,
        2 => expect(near(first, 0.0) && near(last, 180.0), "from C0 to C180")?,
        3 => expect(near(first, 90.0) && near(last, 270.0), "from C90 to C270")?,
        4 => expect(near(first, 0.0) && near(last, 90.0), "from C0 to C90")?,
        _ => {}
    }
    let n_values = count.saturating_mul(ng);
    limits.check(l_ng, "number of intensities", n_values, limits.max_values)?;
    let (candela, l_i) = t.numbers(n_values, "luminous intensity (cd/klm)")?;
    let mut warnings = Vec::new();
    if let Some((tok, line)) = t.next_token() {
        warnings.push(Warning {
            line,
            message: format!(
                "trailing data after the last intensity, ignored: `{}`",
                shorten(tok)
            ),
        });
    }
    if isym == 0 && mc == 1 {
        // A single plane with no symmetry: the only reading is rotational.
        warnings.push(Warning {
            line: l_isym,
            message: "Isym 0 with one C plane read as rotationally symmetric".into(),
        });
    }

    // The intensities are in cd/klm of the flux of every lamp fitted: the sum over the sets.
    let absolute = lamp_sets[0].count < 0;
    let lamps: u64 = lamp_sets.iter().map(|s| s.count.unsigned_abs()).sum();
    let lamp_count = lamps.clamp(1, u64::from(u32::MAX)) as u32;
    let total_flux: f64 = lamp_sets.iter().map(|s| s.flux).sum();
    let total_watts: f64 = lamp_sets.iter().map(|s| s.watts).sum();
    for (what, total) in [("flux", total_flux), ("wattage", total_watts)] {
        if !total.is_finite() {
            return Err(IesError::OutOfRange {
                line: l_sets,
                what: format!("total {what} of the lamp sets"),
                value: total,
                expected: "a finite sum".into(),
            });
        }
    }
    let lamp_types: Vec<&str> = lamp_sets
        .iter()
        .map(|s| s.lamp_type.as_str())
        .filter(|t| !t.is_empty())
        .collect();
    let lamp_types = lamp_types.join("\n");
    let conversion = if nums[11] > 0.0 { nums[11] } else { 1.0 };
    let mut keywords = Vec::new();
    for (key, value) in [
        ("TEST", texts[0]),
        ("MANUFAC", company),
        ("LUMCAT", texts[2]),
        ("LUMINAIRE", texts[1]),
        ("LAMP", lamp_types.as_str()),
        ("ISSUEDATE", texts[4]),
    ] {
        if !value.is_empty() {
            keywords.push(Keyword {
                key: key.into(),
                value: value.into(),
            });
        }
    }
    let (area_l, area_w) = (nums[3], nums[4]);
    // LM-63 signs (length along C0-C180, width along C90-C270, as in LM-63): a round area
    // (width 0) is a circle of diameter `length`. The box height is the largest of the
    // heights in C0, C90, C180, C270: any height above zero makes the sides luminous.
    let height = nums[5..9].iter().fold(0.0f64, |m, h| m.max(h.abs()));
    let dimensions = if area_w == 0.0 && area_l > 0.0 {
        [-area_l / 1000.0, -area_l / 1000.0, height / 1000.0]
    } else {
        [area_w / 1000.0, area_l / 1000.0, height / 1000.0]
    };
    let info = LdtInfo {
        company: company.to_owned(),
        type_indicator: ityp as u8,
        symmetry_indicator: isym as u8,
        c_planes: mc,
        c_step: dc,
        c_angles,
        gamma_count: ng,
        gamma_step: dg,
        report_number: texts[0].to_owned(),
        luminaire_name: texts[1].to_owned(),
        luminaire_number: texts[2].to_owned(),
        file_name: texts[3].to_owned(),
        date_user: texts[4].to_owned(),
        luminaire_size_mm: [nums[0], nums[1], nums[2]],
        luminous_area_mm: [nums[3], nums[4]],
        luminous_height_mm: [nums[5], nums[6], nums[7], nums[8]],
        downward_flux_fraction: nums[9],
        light_output_ratio: nums[10],
        conversion_factor: nums[11],
        measurement_tilt: nums[12],
        lamp_sets: lamp_sets.clone(),
        direct_ratios,
    };
    Photometry::assemble(Parts {
        format: Format::Eulumdat,
        keywords,
        tilt: Tilt::None,
        lamp_count,
        lumens_per_lamp: (!absolute).then(|| total_flux / f64::from(lamp_count)),
        candela_multiplier: conversion * total_flux / 1000.0,
        photometric_type: PhotometricType::C,
        units: Units::Meters,
        dimensions,
        ballast_factor: 1.0,
        ballast_lamp_factor: 1.0,
        input_watts: total_watts,
        vertical_angles: gammas,
        horizontal_angles: horizontal,
        candela,
        ldt: Some(Box::new(info)),
        warnings,
        lines: [l_g, l_c, l_i],
    })
}
