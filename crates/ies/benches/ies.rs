//! Parse throughput (MB/s) and intensity queries per second.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use luxbake_ies::Photometry;
use std::hint::black_box;

const DOWNLIGHT: &str = include_str!("../../scene/lamps/luxbake_downlight.ies");

/// The bundled lamp, plus the largest shared sample files when `../shared` is present.
fn inputs() -> Vec<(String, Vec<u8>)> {
    let mut out = vec![(
        "luxbake_downlight.ies".to_owned(),
        DOWNLIGHT.as_bytes().to_vec(),
    )];
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/photometry");
    for name in ["real-world/rw_8.IES", "luxpy_test_lid_file.ldt"] {
        match std::fs::read(dir.join(name)) {
            Ok(bytes) => out.push((name.rsplit('/').next().unwrap_or(name).to_owned(), bytes)),
            Err(_) => println!("skipped {name}: ../shared not found"),
        }
    }
    out
}

fn parse(c: &mut Criterion) {
    let mut group = c.benchmark_group("parse");
    for (name, bytes) in inputs() {
        group.throughput(Throughput::Bytes(bytes.len() as u64));
        group.bench_function(&name, |b| {
            b.iter(|| Photometry::parse(black_box(&bytes)).expect("sample parses"))
        });
    }
    group.finish();
}

fn queries(c: &mut Criterion) {
    const N: usize = 4096;
    let dirs: Vec<[f64; 3]> = (0..N)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / N as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = 2.399_963 * i as f64;
            [r * phi.cos(), r * phi.sin(), z]
        })
        .collect();
    let dirs32: Vec<[f32; 3]> = dirs.iter().map(|d| d.map(|x| x as f32)).collect();
    let mut group = c.benchmark_group("query");
    group.throughput(Throughput::Elements(N as u64));
    for (name, bytes) in inputs() {
        let lamp = Photometry::parse(&bytes).expect("sample parses");
        group.bench_function(format!("intensity/{name}"), |b| {
            b.iter(|| {
                dirs.iter()
                    .map(|&d| lamp.intensity(black_box(d)))
                    .sum::<f64>()
            })
        });
        let table = lamp.gpu_table();
        group.bench_function(format!("gpu_table_sample/{name}"), |b| {
            b.iter(|| {
                dirs32
                    .iter()
                    .map(|&d| table.sample(black_box(d)))
                    .sum::<f32>()
            })
        });
    }
    group.finish();
    let lamp = Photometry::parse(DOWNLIGHT.as_bytes()).expect("bundled lamp parses");
    c.bench_function("luminous_flux/luxbake_downlight.ies", |b| {
        b.iter(|| black_box(&lamp).luminous_flux())
    });
    c.bench_function("gpu_table/luxbake_downlight.ies", |b| {
        b.iter(|| black_box(&lamp).gpu_table())
    });
}

criterion_group!(benches, parse, queries);
criterion_main!(benches);
