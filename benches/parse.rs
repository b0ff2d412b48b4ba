//! Parse throughput: skylod's reader (XML -> CityModel) against a raw `quick_xml` namespace-
//! resolving event scan of the same bytes, with and without parsing every number, in the same run (the machine is shared and noisy,
//! so only the ratio and same-run figures mean something).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use quick_xml::events::Event;
use quick_xml::NsReader;
use skylod::io::citygml::{read_source, ReadOptions};
use skylod::model::Source;
use std::io::Read;
use std::path::{Path, PathBuf};

fn load(path: &Path) -> Option<Vec<u8>> {
    let raw = std::fs::read(path).ok()?;
    if raw.starts_with(&[0x1f, 0x8b]) {
        let mut out = Vec::new();
        flate2::read::MultiGzDecoder::new(&raw[..])
            .read_to_end(&mut out)
            .ok()?;
        Some(out)
    } else {
        Some(raw)
    }
}

/// The baseline: every event read and its namespace resolved, nothing else.
fn raw_scan(bytes: &[u8]) -> usize {
    let mut r = NsReader::from_reader(bytes);
    let mut buf = Vec::new();
    let mut n = 0usize;
    loop {
        match r.read_resolved_event_into(&mut buf) {
            Ok((_, Event::Eof)) => break,
            Ok((_, Event::Text(t))) => n += t.len(),
            Ok(_) => n += 1,
            Err(_) => break,
        }
        buf.clear();
    }
    n
}

/// The reference of the reader's goal (issue 11, `../shared/tools/qxscan FILE floats`): the
/// same scan, parsing every whitespace-separated number of every text node with `str::parse`.
fn raw_scan_floats(bytes: &[u8]) -> f64 {
    let mut r = NsReader::from_reader(bytes);
    let mut buf = Vec::new();
    let mut sum = 0.0;
    loop {
        match r.read_resolved_event_into(&mut buf) {
            Ok((_, Event::Eof)) | Err(_) => break,
            Ok((_, Event::Text(t))) => {
                for tok in t.split(|b| b.is_ascii_whitespace()) {
                    if let Some(v) = std::str::from_utf8(tok)
                        .ok()
                        .and_then(|s| s.parse::<f64>().ok())
                    {
                        sum += v;
                    }
                }
            }
            Ok(_) => {}
        }
        buf.clear();
    }
    sum
}

fn inputs() -> Vec<(String, Vec<u8>)> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let data = root.join("../shared/data");
    let mut v = Vec::new();
    for (name, rel) in [
        ("ingolstadt-4018215-lod3", "ingolstadt-lod3/4018215.xml.gz"),
        (
            "fzk-haus-lod3-v3",
            "kit-fzk-haus/citygml3/FZK-Haus-LoD3-KIT-IAI-KHH-B36-V1__v3.gml",
        ),
    ] {
        if let Some(b) = load(&data.join(rel)) {
            v.push((name.to_string(), b));
        }
    }
    let synth = root.join("fixtures/synth-small.gml");
    if let Some(b) = load(&synth) {
        v.push(("synth-small-lod3".to_string(), b));
    }
    // a large file of one's own (e.g. `python3 ../shared/tools/bench_inputs.py ../shared/data
    // /tmp/big.gml 56`): SKYLOD_PARSE_BENCH_FILE=/tmp/big.gml cargo bench --bench parse
    if let Some(p) = std::env::var_os("SKYLOD_PARSE_BENCH_FILE") {
        if let Some(b) = load(Path::new(&p)) {
            v.push(("extra".to_string(), b));
        }
    }
    if v.is_empty() {
        eprintln!("parse bench: no input found (../shared/data missing); nothing measured");
    }
    v
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("parse");
    g.sample_size(20);
    for (name, bytes) in inputs() {
        g.throughput(Throughput::Bytes(bytes.len() as u64));
        g.bench_with_input(
            BenchmarkId::new("raw_quick_xml_scan", &name),
            &bytes,
            |b, x| b.iter(|| raw_scan(x)),
        );
        g.bench_with_input(
            BenchmarkId::new("raw_quick_xml_scan_floats", &name),
            &bytes,
            |b, x| b.iter(|| raw_scan_floats(x)),
        );
        // one chunk on one core, and chunks parsed ahead on rayon's threads (the default);
        // the same model either way
        for (id, chunk_bytes) in [("skylod_read_one_chunk", u64::MAX), ("skylod_read", 0)] {
            let opts = ReadOptions {
                chunk_bytes,
                ..ReadOptions::default()
            };
            g.bench_with_input(BenchmarkId::new(id, &name), &bytes, |b, x| {
                b.iter(|| {
                    read_source(
                        Source::Memory(x.as_slice().into()),
                        "bench.gml".as_ref(),
                        &opts,
                        &|_| {},
                    )
                    .map(|m| m.assets.len())
                    .unwrap_or(0)
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
