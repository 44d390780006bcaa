//! Writers: IES LM-63-2002 / LM-63-2019, and EULUMDAT for data read from EULUMDAT.

use crate::Photometry;
use crate::model::{Format, IesVersion, PhotometricType, Tilt, Units};
use std::fmt::{Display, Write as _};

/// Values per output line.
const PER_LINE: usize = 10;

fn push_list(out: &mut String, values: &[f64]) {
    for chunk in values.chunks(PER_LINE) {
        let line: Vec<String> = chunk.iter().map(|v| v.to_string()).collect();
        out.push_str(&line.join(" "));
        out.push('\n');
    }
}

impl Photometry {
    /// Writes the photometry as an LM-63 file of the given version.
    ///
    /// Numbers are written in Rust's shortest round-trip form, so for any photometry read from
    /// an LM-63-2002 (resp. -2019) file, `parse(to_ies(Lm63_2002)) == self` (resp. 2019), warnings
    /// aside. Conversions: label lines without a keyword (LM-63-1986) are written as `[OTHER]`;
    /// `TILT=<file>` is written as `TILT=INCLUDE` with the resolved data, so the output stands
    /// alone; for LM-63-1986/1991 data the ballast-lamp factor (a multiplier there) is folded
    /// into the candela multiplier. EULUMDAT data is written with its cd/klm values and the
    /// multiplier that turns them into candela, so intensities are unchanged. The writer adds
    /// no keyword the source lacks (LM-63-2019 requires `[TEST]`, `[TESTLAB]`, `[ISSUEDATE]`,
    /// `[MANUFAC]`).
    pub fn to_ies(&self, version: IesVersion) -> String {
        let mut out = String::new();
        out.push_str(match version {
            IesVersion::Lm63_2002 => "IESNA:LM-63-2002\n",
            IesVersion::Lm63_2019 => "IES:LM-63-2019\n",
        });
        for k in &self.keywords {
            let key = if k.key.is_empty() { "OTHER" } else { &k.key };
            let mut parts = k.value.split('\n');
            let first = parts.next().unwrap_or("");
            out.push_str(format!("[{key}] {first}").trim_end());
            out.push('\n');
            for more in parts {
                out.push_str(format!("[MORE] {more}").trim_end());
                out.push('\n');
            }
        }
        match &self.tilt {
            Tilt::None => out.push_str("TILT=NONE\n"),
            Tilt::Include(d) | Tilt::File { data: d, .. } => {
                out.push_str("TILT=INCLUDE\n");
                let _ = writeln!(out, "{}", d.lamp_geometry);
                let _ = writeln!(out, "{}", d.angles.len());
                push_list(&mut out, &d.angles);
                push_list(&mut out, &d.factors);
            }
        }
        let (multiplier, blf) = if self.format <= Format::Lm63_1991 {
            (self.candela_multiplier * self.ballast_lamp_factor, 1.0)
        } else {
            (self.candela_multiplier, self.ballast_lamp_factor)
        };
        let [w, l, h] = self.dimensions;
        let _ = writeln!(
            out,
            "{} {} {} {} {} {} {} {} {} {}",
            self.lamp_count,
            self.lumens_per_lamp.unwrap_or(-1.0),
            multiplier,
            self.vertical_angles.len(),
            self.horizontal_angles.len(),
            match self.photometric_type {
                PhotometricType::C => 1,
                PhotometricType::B => 2,
                PhotometricType::A => 3,
            },
            match self.units {
                Units::Feet => 1,
                Units::Meters => 2,
            },
            w,
            l,
            h
        );
        let _ = writeln!(out, "{} {} {}", self.ballast_factor, blf, self.input_watts);
        push_list(&mut out, &self.vertical_angles);
        push_list(&mut out, &self.horizontal_angles);
        let nv = self.vertical_angles.len().max(1);
        for row in self.candela.chunks(nv) {
            push_list(&mut out, row);
        }
        out
    }

    /// Writes the photometry as a EULUMDAT file, one field per line, numbers in Rust's
    /// shortest round-trip form, so `parse(to_ldt()) == self` (warnings aside) with every lamp
    /// set and every C angle. `None` for data not read from EULUMDAT: LM-63 data has no
    /// EULUMDAT header to write.
    pub fn to_ldt(&self) -> Option<String> {
        let l = self.ldt.as_deref()?;
        let mut out = String::new();
        let mut put = |v: &dyn Display| {
            let _ = writeln!(out, "{v}");
        };
        put(&l.company);
        put(&l.type_indicator);
        put(&l.symmetry_indicator);
        put(&l.c_angles.len());
        put(&l.c_step);
        put(&self.vertical_angles.len());
        put(&l.gamma_step);
        for text in [
            &l.report_number,
            &l.luminaire_name,
            &l.luminaire_number,
            &l.file_name,
            &l.date_user,
        ] {
            put(text);
        }
        let numbers = l.luminaire_size_mm.iter().chain(&l.luminous_area_mm);
        let numbers = numbers.chain(&l.luminous_height_mm);
        for v in numbers {
            put(v);
        }
        for v in [
            l.downward_flux_fraction,
            l.light_output_ratio,
            l.conversion_factor,
            l.measurement_tilt,
        ] {
            put(&v);
        }
        put(&l.lamp_sets.len());
        let sets = &l.lamp_sets;
        sets.iter().for_each(|s| put(&s.count));
        sets.iter().for_each(|s| put(&s.lamp_type));
        sets.iter().for_each(|s| put(&s.flux));
        sets.iter().for_each(|s| put(&s.color));
        sets.iter().for_each(|s| put(&s.cri));
        sets.iter().for_each(|s| put(&s.watts));
        let data = l.direct_ratios.iter().chain(&l.c_angles);
        for v in data.chain(&self.vertical_angles).chain(&self.candela) {
            put(v);
        }
        Some(out)
    }
}
