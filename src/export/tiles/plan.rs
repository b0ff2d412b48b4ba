//! The tree of a tileset: a quadtree over the model's extent in its east-north-up frame.
//!
//! The model is cut into units that stay whole (a building with all its parts and surfaces,
//! or an object outside buildings), each placed by the centre of its box. A square is split
//! into its four quarters while it holds more than one unit and more than [`LEAF_VERTICES`]
//! vertices; empty quarters get no tile. Leaves hold full detail; every other tile holds the
//! rough forms of what lies below it.

use glam::DVec2;

/// The most vertices (of full detail) a leaf holds unless it is a single unit: a few MB of
/// glTF, what web viewers load comfortably in one request.
pub(super) const LEAF_VERTICES: u64 = 100_000;

/// Deepest level of the tree (the root is level 0).
const MAX_LEVEL: u32 = 20;

/// A unit of the model (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Unit {
    /// Centre of its box, east and north in the model's frame (m).
    pub at: DVec2,
    /// Vertices of its full detail.
    pub weight: u64,
}

/// A tile of the tree.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Node {
    /// Level (0 the root) and position of its square among the level's `2^level × 2^level`.
    pub level: u32,
    pub x: u32,
    pub y: u32,
    /// Side of its square (m).
    pub side: f64,
    /// Its children's indices into [`Tree::nodes`] (none for a leaf).
    pub children: Vec<usize>,
}

impl Node {
    /// The name of its content, relative to the tileset: `tiles/<level>/<x>_<y>.glb`.
    pub fn content_uri(&self) -> String {
        format!("tiles/{}/{}_{}.glb", self.level, self.x, self.y)
    }
}

/// The tree and where each unit went.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Tree {
    /// Tiles, the root first, each before its children.
    pub nodes: Vec<Node>,
    /// The leaf (an index into `nodes`) of each unit.
    pub leaf_of_unit: Vec<u32>,
}

impl Tree {
    /// Parents before children, deepest last: the order in which a tile's children are
    /// written before it is reading this backwards.
    pub fn leaves(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.nodes.len()).filter(|&n| self.nodes[n].children.is_empty())
    }

    /// The leaves below node `n` (itself for a leaf).
    pub fn leaves_below(&self, n: usize) -> Vec<usize> {
        let mut out = Vec::new();
        let mut stack = vec![n];
        while let Some(k) = stack.pop() {
            let node = &self.nodes[k];
            if node.children.is_empty() {
                out.push(k);
            } else {
                stack.extend(node.children.iter().rev());
            }
        }
        out
    }
}

/// The quadtree of `units` (see the module docs).
pub(super) fn plan(units: &[Unit], leaf_vertices: u64) -> Tree {
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for u in units {
        lo = lo.min(u.at);
        hi = hi.max(u.at);
    }
    if units.is_empty() {
        (lo, hi) = (DVec2::ZERO, DVec2::ZERO);
    }
    // a square a little larger than the centres' extent: none on its far edges
    let side = (hi - lo).max_element().max(1.0) * (1.0 + 1e-9) + 1e-6;
    let mut tree = Tree {
        nodes: Vec::new(),
        leaf_of_unit: vec![0; units.len()],
    };
    let all: Vec<u32> = (0..units.len() as u32).collect();
    split(&mut tree, units, all, (0, 0, 0), lo, side, leaf_vertices);
    tree
}

/// Add the node of square (`level`, `x`, `y`) at `origin` with `side`, holding `members`,
/// and its subtree; its index. A square whose members all lie in one quarter becomes that
/// quarter (no tile holds exactly what its only child holds).
fn split(
    tree: &mut Tree,
    units: &[Unit],
    members: Vec<u32>,
    (mut level, mut x, mut y): (u32, u32, u32),
    mut origin: DVec2,
    mut side: f64,
    leaf_vertices: u64,
) -> usize {
    let weight: u64 = members.iter().map(|&u| units[u as usize].weight).sum();
    let mut quarters: [Vec<u32>; 4] = Default::default();
    let divide = loop {
        if members.len() <= 1 || weight <= leaf_vertices || level >= MAX_LEVEL {
            break false;
        }
        let half = side / 2.0;
        quarters = Default::default();
        for &u in &members {
            let d = units[u as usize].at - origin;
            let q = usize::from(d.x >= half) + 2 * usize::from(d.y >= half);
            quarters[q].push(u);
        }
        let full: Vec<usize> = (0..4).filter(|&q| !quarters[q].is_empty()).collect();
        if full.len() > 1 {
            break true;
        }
        let q = full[0];
        let (dx, dy) = ((q % 2) as u32, (q / 2) as u32);
        origin += DVec2::new(f64::from(dx), f64::from(dy)) * half;
        (level, x, y, side) = (level + 1, 2 * x + dx, 2 * y + dy, half);
    };
    let me = tree.nodes.len();
    tree.nodes.push(Node {
        level,
        x,
        y,
        side,
        children: Vec::new(),
    });
    if !divide {
        for &u in &members {
            tree.leaf_of_unit[u as usize] = me as u32;
        }
        return me;
    }
    let half = side / 2.0;
    for (q, part) in quarters.into_iter().enumerate() {
        if part.is_empty() {
            continue;
        }
        let (dx, dy) = ((q % 2) as u32, (q / 2) as u32);
        let o = origin + DVec2::new(f64::from(dx), f64::from(dy)) * half;
        let cell = (level + 1, 2 * x + dx, 2 * y + dy);
        let child = split(tree, units, part, cell, o, half, leaf_vertices);
        tree.nodes[me].children.push(child);
    }
    me
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(x: f64, y: f64, weight: u64) -> Unit {
        Unit {
            at: DVec2::new(x, y),
            weight,
        }
    }

    #[test]
    fn small_models_are_one_leaf() {
        let t = plan(&[unit(0.0, 0.0, 10), unit(5.0, 5.0, 10)], 100);
        assert_eq!(t.nodes.len(), 1);
        assert_eq!(t.leaf_of_unit, vec![0, 0]);
        assert_eq!(t.nodes[0].content_uri(), "tiles/0/0_0.glb");
        let empty = plan(&[], 100);
        assert_eq!(empty.nodes.len(), 1);
    }

    #[test]
    fn quarters_until_leaves_fit() {
        // four corners of a 100 m square, 60 vertices each; leaves of at most 100
        let units = [
            unit(0.0, 0.0, 60),
            unit(100.0, 0.0, 60),
            unit(0.0, 100.0, 60),
            unit(100.0, 100.0, 60),
            unit(1.0, 1.0, 60),
        ];
        let t = plan(&units, 100);
        let root = &t.nodes[0];
        assert_eq!(root.children.len(), 4);
        // the two units of the lower-left quarter share it, so it is split again, at the
        // square where they part (a square whose units share one quarter is that quarter)
        let ll = &t.nodes[root.children[0]];
        assert_eq!((ll.x, ll.y), (0, 0));
        assert!(ll.level > 1 && ll.children.len() == 2, "{ll:?}");
        // units at one point: one leaf, however heavy
        let same = [unit(3.0, 3.0, 60), unit(3.0, 3.0, 60), unit(3.0, 3.0, 60)];
        let t1 = plan(&same, 100);
        assert_eq!(t1.nodes.len(), 1);
        // every unit in a leaf, every leaf under the root, no leaf over the limit but singles
        for (u, &leaf) in t.leaf_of_unit.iter().enumerate() {
            assert!(t.nodes[leaf as usize].children.is_empty(), "unit {u}");
        }
        let mut below = t.leaves_below(0);
        below.sort_unstable();
        let mut leaves: Vec<usize> = t.leaves().collect();
        leaves.sort_unstable();
        assert_eq!(below, leaves);
        let upper_right = &t.nodes[t.leaf_of_unit[3] as usize];
        assert_eq!((upper_right.level, upper_right.x, upper_right.y), (1, 1, 1));
    }
}
