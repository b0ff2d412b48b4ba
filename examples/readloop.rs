//! Profiling helper: skylod's reader on an uncompressed file, N times, with MB/s.
//! `cargo run --release --example readloop -- FILE.gml [N=20]`
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let bytes = std::fs::read(&args[1]).unwrap();
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(20);
    let t = std::time::Instant::now();
    let mut a = 0;
    for _ in 0..n {
        a += skylod::io::citygml::read_bytes(&bytes, "x")
            .unwrap()
            .assets
            .len();
    }
    let dt = t.elapsed().as_secs_f64() / n as f64;
    println!(
        "{a} {:.2} ms/iter {:.1} MB/s",
        dt * 1e3,
        bytes.len() as f64 / dt / 1e6
    );
}
