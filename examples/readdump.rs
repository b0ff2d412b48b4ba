//! Check helper: for each file, a hash of the `Debug` form of the model the reader returns
//! (or its error), to compare two builds of the reader on many files.
//! `cargo run --release --example readdump -- FILES...`
use std::hash::{Hash, Hasher};
fn main() {
    for p in std::env::args().skip(1) {
        let s = match skylod::io::citygml::read_file(std::path::Path::new(&p)) {
            Ok(m) => format!("{m:?}"),
            Err(e) => format!("ERROR {e} / {e:?}"),
        };
        let mut h = std::collections::hash_map::DefaultHasher::new();
        s.hash(&mut h);
        println!("{p} {} {:016x}", s.len(), h.finish());
    }
}
