//! Property tests: no input panics; the writer round-trips; symmetric files give symmetric
//! intensities.

use luxbake_ies::{IesVersion, Photometry};
use proptest::prelude::*;

const DOWNLIGHT: &str = include_str!("../../scene/lamps/luxbake_downlight.ies");

/// `n` strictly increasing angles from `lo` to `hi` (inclusive) with random spacing.
fn angles(n: usize, lo: f64, hi: f64) -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(1.0f64..10.0, n - 1).prop_map(move |steps| {
        let total: f64 = steps.iter().sum();
        let mut out = vec![lo];
        let mut acc = 0.0;
        for s in &steps[..steps.len() - 1] {
            acc += s;
            out.push(lo + (hi - lo) * acc / total);
        }
        out.push(hi);
        out
    })
}

/// Horizontal ranges: (first, last) for each LM-63 type C symmetry; `None` = one plane.
const C_RANGES: [Option<(f64, f64)>; 5] = [
    None,
    Some((0.0, 90.0)),
    Some((0.0, 180.0)),
    Some((90.0, 270.0)),
    Some((0.0, 360.0)),
];

#[derive(Debug, Clone)]
struct File {
    ptype: u8,
    vertical: Vec<f64>,
    horizontal: Vec<f64>,
    candela: Vec<f64>,
    keywords: Vec<(String, Vec<String>)>,
    tilt: Option<(u8, Vec<f64>, Vec<f64>)>,
    header: [f64; 6],
}

impl File {
    fn text(&self) -> String {
        let list = |x: &[f64]| {
            x.iter()
                .map(|a| a.to_string())
                .collect::<Vec<_>>()
                .join(" ")
        };
        let mut s = String::from("IESNA:LM-63-2002\n");
        for (k, parts) in &self.keywords {
            s += &format!("[{k}] {}\n", parts[0]);
            for more in &parts[1..] {
                s += &format!("[MORE] {more}\n");
            }
        }
        match &self.tilt {
            None => s += "TILT=NONE\n",
            Some((g, a, f)) => {
                s += &format!("TILT=INCLUDE\n{g}\n{}\n{}\n{}\n", a.len(), list(a), list(f))
            }
        }
        let [lumens, mult, w, l, h, bf] = self.header;
        s += &format!(
            "2 {lumens} {mult} {} {} {} 2 {w} {l} {h}\n{bf} 1 12.5\n",
            self.vertical.len(),
            self.horizontal.len(),
            self.ptype
        );
        s += &format!(
            "{}\n{}\n{}\n",
            list(&self.vertical),
            list(&self.horizontal),
            list(&self.candela)
        );
        s
    }
}

fn value() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0),
        0.0f64..1.0,
        0.0f64..1e5,
        (0u32..100_000).prop_map(f64::from)
    ]
}

fn keyword() -> impl Strategy<Value = (String, Vec<String>)> {
    (
        "[A-Z_][A-Z0-9_]{0,11}",
        prop::collection::vec("[!-~]([ -~]{0,30}[!-~])?", 1..3),
    )
        .prop_filter("MORE is a continuation", |(k, _)| k != "MORE")
}

fn type_c_file() -> impl Strategy<Value = File> {
    (
        prop::sample::select(&C_RANGES[..]),
        prop::sample::select(&[(0.0, 90.0), (90.0, 180.0), (0.0, 180.0)][..]),
        2usize..10,
        2usize..8,
    )
        .prop_flat_map(|(h_range, (v_lo, v_hi), nv, nh)| {
            let horizontal = match h_range {
                None => Just(vec![0.0]).boxed(),
                Some((lo, hi)) => angles(nh, lo, hi).boxed(),
            };
            (Just(1u8), angles(nv, v_lo, v_hi), horizontal)
        })
        .prop_flat_map(file_from_angles)
}

fn type_ab_file() -> impl Strategy<Value = File> {
    (
        prop::sample::select(&[2u8, 3][..]),
        any::<bool>(),
        2usize..8,
        2usize..8,
    )
        .prop_flat_map(|(ptype, mirrored, nv, nh)| {
            let h_lo = if mirrored { 0.0 } else { -90.0 };
            (Just(ptype), angles(nv, -90.0, 90.0), angles(nh, h_lo, 90.0))
        })
        .prop_flat_map(file_from_angles)
}

fn file_from_angles(
    (ptype, vertical, horizontal): (u8, Vec<f64>, Vec<f64>),
) -> impl Strategy<Value = File> {
    let n = vertical.len() * horizontal.len();
    (
        prop::collection::vec(value(), n),
        prop::collection::vec(keyword(), 0..4),
        prop::option::of(
            (1u8..=3, 1usize..5)
                .prop_flat_map(|(g, k)| (Just(g), prop::collection::vec(0.0f64..2.0, k))),
        ),
        (
            value(),
            0.01f64..10.0,
            -2.0f64..2.0,
            -2.0f64..2.0,
            -1.0f64..1.0,
            0.1f64..1.5,
        ),
    )
        .prop_map(
            move |(candela, keywords, tilt, (lumens, mult, w, l, h, bf))| File {
                ptype,
                vertical: vertical.clone(),
                horizontal: horizontal.clone(),
                candela,
                keywords,
                tilt: tilt.map(|(g, f)| {
                    let a = (0..f.len()).map(|i| i as f64 * 15.0).collect();
                    (g, a, f)
                }),
                header: [lumens, mult, w, l, h, bf],
            },
        )
}

/// A lamp set: lamps, type, flux, colour, CRI, watts.
type Set = (i64, String, f64, String, String, f64);

/// A EULUMDAT file: symmetry, C planes, γ angles, stored intensities, header texts and
/// numbers, lamp sets (one sign for every count).
#[derive(Debug, Clone)]
struct Ldt {
    isym: u8,
    mc: usize,
    gammas: Vec<f64>,
    candela: Vec<f64>,
    texts: Vec<String>,
    numbers: Vec<f64>,
    sets: Vec<Set>,
}

impl Ldt {
    fn text(&self) -> String {
        let dc = 360.0 / self.mc as f64;
        let mut s = format!(
            "{}\n1\n{}\n{}\n{dc}\n{}\n5\n",
            self.texts[0],
            self.isym,
            self.mc,
            self.gammas.len()
        );
        for t in &self.texts[1..] {
            s += &format!("{t}\n");
        }
        for v in &self.numbers {
            s += &format!("{v}\n");
        }
        s += &format!("{}\n", self.sets.len());
        let sets = &self.sets;
        let field =
            |f: &dyn Fn(&Set) -> String| sets.iter().map(|x| f(x) + "\n").collect::<String>();
        s += &field(&|x| x.0.to_string());
        s += &field(&|x| x.1.clone());
        s += &field(&|x| x.2.to_string());
        s += &field(&|x| x.3.clone());
        s += &field(&|x| x.4.clone());
        s += &field(&|x| x.5.to_string());
        for k in 0..10 {
            s += &format!("{}\n", 0.1 * k as f64);
        }
        for i in 0..self.mc {
            s += &format!("{}\n", i as f64 * dc);
        }
        for v in self.gammas.iter().chain(&self.candela) {
            s += &format!("{v}\n");
        }
        s
    }
}

/// Header text: never read as the start of an LM-63 file (`TILT`, `IES`).
fn ldt_text() -> impl Strategy<Value = String> {
    "[A-Za-z0-9 ./-]{0,16}".prop_filter("not an LM-63 marker", |t| {
        let up = t.trim().to_ascii_uppercase();
        !(up.starts_with("TILT") || up.starts_with("IES"))
    })
}

fn ldt_file() -> impl Strategy<Value = Ldt> {
    (0u8..=4, 1usize..5, 2usize..8, 1usize..5, any::<bool>())
        .prop_flat_map(|(isym, k, ng, n_sets, absolute)| {
            let mc = 4 * k;
            let stored = match isym {
                0 => mc,
                1 => 1,
                2 | 3 => mc / 2 + 1,
                _ => mc / 4 + 1,
            };
            let sign = if absolute { -1 } else { 1 };
            let set = (
                1i64..5,
                ldt_text(),
                0.0f64..1e5,
                ldt_text(),
                ldt_text(),
                0.0f64..500.0,
            )
                .prop_map(move |(n, t, f, c, r, w)| (sign * n, t, f, c, r, w));
            (
                Just((isym, mc)),
                angles(ng, 0.0, 180.0),
                prop::collection::vec(value(), stored * ng),
                prop::collection::vec(ldt_text(), 6),
                prop::collection::vec(0.0f64..2000.0, 13),
                prop::collection::vec(set, n_sets),
            )
        })
        .prop_map(|((isym, mc), gammas, candela, texts, numbers, sets)| Ldt {
            isym,
            mc,
            gammas,
            candela,
            texts,
            numbers,
            sets,
        })
}

fn direction() -> impl Strategy<Value = [f64; 3]> {
    [-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0]
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..2000)) {
        let _ = Photometry::parse(&bytes);
    }

    #[test]
    fn mutated_files_never_panic(
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>(), 0u8..3), 1..8),
        ldt in any::<bool>(),
    ) {
        let base = if ldt { lamp_ldt() } else { DOWNLIGHT.as_bytes().to_vec() };
        let mut bytes = base;
        for (at, byte, op) in edits {
            let i = at.index(bytes.len().max(1)).min(bytes.len());
            match op {
                0 if i < bytes.len() => bytes[i] = byte,
                1 => bytes.insert(i, byte),
                _ if i < bytes.len() => { bytes.remove(i); }
                _ => {}
            }
        }
        if let Ok(p) = Photometry::parse(&bytes) {
            let flux = p.luminous_flux();
            prop_assert!(flux.is_finite() && flux >= 0.0);
            prop_assert!(p.intensity([0.3, -0.2, -1.0]).is_finite());
        }
    }

    #[test]
    fn writer_round_trips(file in prop_oneof![type_c_file(), type_ab_file()]) {
        let text = file.text();
        let p = Photometry::parse(text.as_bytes()).map_err(|e| TestCaseError::fail(format!("{e}\n{text}")))?;
        for v in [IesVersion::Lm63_2002, IesVersion::Lm63_2019] {
            let q = Photometry::parse(p.to_ies(v).as_bytes()).unwrap();
            let again = Photometry::parse(q.to_ies(v).as_bytes()).unwrap();
            prop_assert_eq!(&q, &again);
            if v == IesVersion::Lm63_2002 {
                prop_assert_eq!(&p, &q);
            }
        }
    }

    #[test]
    fn ldt_writer_round_trips_every_lamp_set(file in ldt_file()) {
        let text = file.text();
        let p = Photometry::parse(text.as_bytes()).map_err(|e| TestCaseError::fail(format!("{e}\n{text}")))?;
        let info = p.ldt().expect("EULUMDAT");
        prop_assert_eq!(info.lamp_sets.len(), file.sets.len());
        for (set, (n, t, f, c, r, w)) in info.lamp_sets.iter().zip(&file.sets) {
            prop_assert_eq!((set.count, &set.lamp_type, set.flux), (*n, &t.trim().to_owned(), *f));
            prop_assert_eq!((&set.color, &set.cri, set.watts), (&c.trim().to_owned(), &r.trim().to_owned(), *w));
        }
        // Intensities in cd/klm of every set's flux, times the conversion factor.
        let total: f64 = file.sets.iter().map(|s| s.2).sum();
        let conversion = if file.numbers[11] > 0.0 { file.numbers[11] } else { 1.0 };
        prop_assert!(close(p.candela_multiplier(), conversion * total / 1000.0));
        let written = p.to_ldt().expect("read from EULUMDAT");
        let q = Photometry::parse(written.as_bytes()).map_err(|e| TestCaseError::fail(format!("{e}\n{written}")))?;
        prop_assert_eq!(&q, &p);
        prop_assert_eq!(q.to_ldt().expect("EULUMDAT"), written);
    }

    #[test]
    fn symmetric_files_give_symmetric_intensities(file in type_c_file(), d in direction()) {
        let p = Photometry::parse(file.text().as_bytes()).unwrap();
        let [x, y, z] = d;
        let a = p.intensity(d);
        let h = &file.horizontal;
        let (first, last) = (h[0], h[h.len() - 1]);
        let mirrors: Vec<[f64; 3]> = if h.len() == 1 {
            // Rotational: any rotation about the vertical axis.
            vec![[-y, x, z], [-x, -y, z], [0.6 * x - 0.8 * y, 0.8 * x + 0.6 * y, z]]
        } else if last == 90.0 {
            vec![[x, -y, z], [-x, y, z], [-x, -y, z]]
        } else if last == 180.0 {
            vec![[x, -y, z]]
        } else if first == 90.0 {
            vec![[-x, y, z]]
        } else {
            vec![]
        };
        for m in mirrors {
            let b = p.intensity(m);
            prop_assert!(close(a, b), "{:?} {} vs {:?} {}", d, a, m, b);
        }
    }

    #[test]
    fn lateral_symmetry_for_types_a_and_b(file in type_ab_file(), d in direction()) {
        prop_assume!(file.horizontal[0] == 0.0);
        let p = Photometry::parse(file.text().as_bytes()).unwrap();
        let [x, y, z] = d;
        let (a, b) = (p.intensity(d), p.intensity([x, -y, z]));
        prop_assert!(close(a, b), "{} vs {}", a, b);
    }

    #[test]
    fn gpu_table_matches_random_files(file in type_c_file(), d in direction()) {
        let p = Photometry::parse(file.text().as_bytes()).unwrap();
        let table = p.gpu_table();
        prop_assert!(table.width <= 2048);
        let s = f64::from(table.sample([d[0] as f32, d[1] as f32, d[2] as f32]));
        // Exact up to f32 rounding away from the edges where the data stops; near them the
        // table ramps over one cell, bounded by the peak.
        let (max, _) = p.max_intensity();
        prop_assert!(s >= -1e-3 && s <= max * 1.0001 + 1e-3, "{} > {}", s, max);
    }
}

/// A small EULUMDAT file for the mutation test.
fn lamp_ldt() -> Vec<u8> {
    let mut s = String::from("Acme\n1\n2\n4\n90\n3\n45\nR\nN\nL\nF\nD\n");
    s += "100\n0\n50\n80\n0\n0\n0\n0\n0\n100\n100\n1\n0\n1\n1\nLED\n1000\n3000K\n90\n10\n";
    for _ in 0..10 {
        s += "0.5\n";
    }
    s += "0\n90\n180\n270\n0\n45\n90\n";
    s += "300\n200\n0\n310\n210\n0\n320\n220\n0\n";
    s.into_bytes()
}
