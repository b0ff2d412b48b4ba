//! Reads each file given and prints its time and asset count (or the error): a quick check of
//! the reader on a folder of data. `cargo run --release --example scan -- FILES...`
fn main() {
    for p in std::env::args().skip(1) {
        let t = std::time::Instant::now();
        match skylod::io::citygml::read_file(std::path::Path::new(&p)) {
            Ok(m) => {
                let s = skylod::export::report::Stats::of(&m);
                println!(
                    "{p}: {:?} {:.1}ms",
                    serde_json::to_string(&s).unwrap(),
                    t.elapsed().as_secs_f64() * 1e3
                );
                for w in m.warnings.iter().take(2) {
                    println!("   W {w}");
                }
            }
            Err(e) => println!("{p}: ERROR {e}"),
        }
    }
}
