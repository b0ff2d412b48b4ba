//! Profiling helper: a raw quick_xml namespace-resolving scan of an uncompressed file, N times
//! (the baseline of `benches/parse.rs`), for perf/callgrind next to `readloop`.
//! `cargo run --release --example rawscan -- FILE.gml [N=20]`
use quick_xml::events::Event;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let bytes = std::fs::read(&args[1]).unwrap();
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(20);
    let t = std::time::Instant::now();
    let mut c = 0usize;
    for _ in 0..n {
        let mut r = quick_xml::NsReader::from_reader(&bytes[..]);
        let mut buf = Vec::new();
        loop {
            match r.read_resolved_event_into(&mut buf) {
                Ok((_, Event::Eof)) | Err(_) => break,
                Ok(_) => c += 1,
            }
            buf.clear();
        }
    }
    let dt = t.elapsed().as_secs_f64() / n as f64;
    println!(
        "{c} {:.2} ms/iter {:.1} MB/s",
        dt * 1e3,
        bytes.len() as f64 / dt / 1e6
    );
}
