//! Generation speed of the synthetic district (Small and Paper presets) into `io::sink()`,
//! against baselines measured in the same run: copying the same number of pre-formatted
//! bytes into a reused buffer (memory bandwidth bound), and formatting the same number of
//! coordinates with `std::fmt` (`{:.3}`), as a naive writer would. Criterion reports MB/s
//! (group `synth-bytes`) and polygons/s (group `synth-polygons`).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use skylod::model::synth::{generate, Preset};
use std::hint::black_box;
use std::io::Write;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    for preset in [Preset::Small, Preset::Paper] {
        let opts = preset.defaults();
        let mut text = Vec::new();
        let sum = match generate(&opts, &mut text) {
            Ok(s) => s,
            Err(e) => panic!("generate failed: {e}"),
        };
        let coords = text.split(|b| *b == b' ').count();
        let name = preset.as_str();

        let mut g = c.benchmark_group("synth-bytes");
        g.sample_size(10)
            .measurement_time(Duration::from_secs(if preset == Preset::Paper {
                12
            } else {
                3
            }))
            .throughput(Throughput::Bytes(sum.bytes));
        g.bench_function(format!("{name}/generate"), |b| {
            b.iter(|| generate(black_box(&opts), std::io::sink()).map(|s| s.polygons))
        });
        let mut buf: Vec<u8> = Vec::with_capacity(text.len());
        g.bench_function(format!("{name}/baseline-copy-preformatted"), |b| {
            b.iter(|| {
                buf.clear();
                for chunk in text.chunks(1 << 16) {
                    buf.extend_from_slice(black_box(chunk));
                }
                buf.len()
            })
        });
        g.bench_function(format!("{name}/baseline-std-fmt-coords"), |b| {
            b.iter(|| {
                buf.clear();
                let mut v = 430_000.123_4f64;
                for _ in 0..coords {
                    let _ = write!(buf, "{:.3} ", black_box(v));
                    v += 0.731;
                }
                buf.len()
            })
        });
        g.finish();

        let mut g = c.benchmark_group("synth-polygons");
        g.sample_size(10)
            .measurement_time(Duration::from_secs(if preset == Preset::Paper {
                12
            } else {
                3
            }))
            .throughput(Throughput::Elements(sum.polygons));
        g.bench_function(format!("{name}/generate"), |b| {
            b.iter(|| generate(black_box(&opts), std::io::sink()).map(|s| s.polygons))
        });
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
