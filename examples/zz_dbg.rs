use glam::DVec3;
fn main() {
    let mut m = skylod::model::CityModel::default();
    let mut files: Vec<_> = std::fs::read_dir("../shared/data/ingolstadt-lod3")
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.to_string_lossy().ends_with(".xml.gz"))
        .collect();
    files.sort();
    for f in &files {
        if let Ok(x) = skylod::citygml::read_file(f) {
            m.merge(x);
        }
    }
    let p = DVec3::new(678095.0, 5403890.0, 418.0);
    let mut best = (f64::INFINITY, 0usize);
    let mut walls = Vec::new();
    for (i, a) in m.assets.iter().enumerate() {
        for poly in a.detail_polygons() {
            let c = poly.exterior.iter().copied().sum::<DVec3>() / poly.exterior.len() as f64;
            let d = (c - p).length();
            if d < best.0 {
                best = (d, i);
            }
            if a.kind == skylod::model::AssetKind::Wall && poly.interiors.is_empty() {
                walls.push((poly.area(), i, c, poly.newell_normal().normalize()));
            }
        }
    }
    let a = &m.assets[best.1];
    println!(
        "nearest to README POI: {:.2} m, {:?} {:?} file {}",
        best.0,
        a.kind,
        a.id,
        m.files[a.file].path.display()
    );
    walls.sort_by(|x, y| y.0.partial_cmp(&x.0).unwrap());
    let mut seen = std::collections::HashSet::new();
    for (area, i, c, n) in walls.iter() {
        let b = m.assets[*i].building;
        if !seen.insert(b) || n.z.abs() > 0.1 {
            continue;
        }
        println!(
            "area {area:.1} bld {:?} file {} c {:.3},{:.3},{:.3} n {:.4},{:.4},{:.4}",
            m.buildings[b.unwrap()].id,
            m.files[m.assets[*i].file]
                .path
                .file_name()
                .unwrap()
                .to_string_lossy(),
            c.x,
            c.y,
            c.z,
            n.x,
            n.y,
            n.z
        );
        if seen.len() > 12 {
            break;
        }
    }
    println!("files {} assets {}", m.files.len(), m.assets.len());
}
