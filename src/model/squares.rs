//! Points grouped by the squares of a grid, the unit of work where a city's points are done
//! one neighbourhood at a time (a cadastre's scenes, the test that drops points inside
//! solids).

use super::Bbox;
use glam::DVec3;
use std::collections::BTreeMap;

/// The points (indices into `points`) in each square of side `size` (x and y) of the grid
/// whose corner is `origin`, with the square's box (z 0 to 0), squares in grid order (rows
/// of increasing y, then x) and points in their order. Which square a point is in depends
/// on the point, `origin` and `size` alone.
///
/// # Example
/// ```
/// use glam::DVec3;
/// let p = [DVec3::new(1.0, 1.0, 0.0), DVec3::new(12.0, 1.0, 5.0), DVec3::new(2.0, 3.0, 9.0)];
/// let s = skylod::model::squares(&p, DVec3::ZERO, 10.0);
/// assert_eq!(s.iter().map(|(_, m)| m.clone()).collect::<Vec<_>>(), [vec![0, 2], vec![1]]);
/// assert_eq!((s[1].0.min.x, s[1].0.max.x), (10.0, 20.0));
/// ```
pub fn squares(points: &[DVec3], origin: DVec3, size: f64) -> Vec<(Bbox, Vec<usize>)> {
    let mut cells: BTreeMap<(i64, i64), Vec<usize>> = BTreeMap::new();
    for (i, p) in points.iter().enumerate() {
        let d = (*p - origin) / size;
        // `as` saturates: a point out of the grid's numbers joins the square at its edge
        cells
            .entry((d.y.floor() as i64, d.x.floor() as i64))
            .or_default()
            .push(i);
    }
    cells
        .into_iter()
        .map(|((y, x), members)| {
            let lo = DVec3::new(origin.x + x as f64 * size, origin.y + y as f64 * size, 0.0);
            let mut b = Bbox::EMPTY;
            b.add(lo);
            b.add(lo + DVec3::new(size, size, 0.0));
            (b, members)
        })
        .collect()
}
