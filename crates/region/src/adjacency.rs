//! Which triangles touch which: triangles that share a vertex *position* (not only an index, so
//! a map whose surfaces each have their own vertices still connects), for GVS++'s sampling of
//! the neighbours of what it found (`gvspp/neighbours.rs`).
//!
//! Memory: 4 bytes per vertex (its welded id), 4 per welded vertex (the offsets) and 12 per
//! triangle (the lists): about 16-20 bytes per triangle, 20 MB for a 1M-triangle scene. Building
//! it takes one hash-map pass over the vertices and two over the triangles (about 50 ms for 1M
//! triangles on one core). A bake builds it once per scene: [`VertexNeighbours::shared`] keeps
//! the last scene's, keyed by the scene's contents.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use sightline_core::Scene;

/// For each welded vertex position, the triangles using it (compressed rows).
#[derive(Debug)]
pub struct VertexNeighbours {
    /// Welded id of each scene vertex.
    welded: Vec<u32>,
    /// Row `w` of the lists is `triangles[offsets[w]..offsets[w + 1]]`.
    offsets: Vec<u32>,
    triangles: Vec<u32>,
}

impl VertexNeighbours {
    /// Builds the lists of `scene`.
    pub fn build(scene: &Scene) -> Self {
        let mut ids: HashMap<[u32; 3], u32> = HashMap::with_capacity(scene.positions.len());
        let welded: Vec<u32> = scene
            .positions
            .iter()
            .map(|p| {
                // -0.0 and 0.0 are the same place.
                let key = p.to_array().map(|c| (c + 0.0).to_bits());
                let next = ids.len() as u32;
                *ids.entry(key).or_insert(next)
            })
            .collect();
        let mut offsets = vec![0u32; ids.len() + 1];
        for t in &scene.triangles {
            for &v in t {
                offsets[welded[v as usize] as usize + 1] += 1;
            }
        }
        for w in 1..offsets.len() {
            offsets[w] += offsets[w - 1];
        }
        let mut fill = offsets.clone();
        let mut triangles = vec![0u32; offsets[ids.len()] as usize];
        for (id, t) in scene.triangles.iter().enumerate() {
            for &v in t {
                let w = welded[v as usize] as usize;
                triangles[fill[w] as usize] = id as u32;
                fill[w] += 1;
            }
        }
        Self {
            welded,
            offsets,
            triangles,
        }
    }

    /// The lists of `scene`, built once per scene: the last scene's lists are kept and
    /// returned while the scene asked about has the same contents (a hash of its positions and
    /// triangles, so a changed or different scene is never answered with stale lists).
    pub fn shared(scene: &Scene) -> Arc<Self> {
        static LAST: Mutex<Option<(u64, Arc<VertexNeighbours>)>> = Mutex::new(None);
        let key = contents_hash(scene);
        let mut last = LAST.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        if let Some((k, lists)) = last.as_ref() {
            if *k == key {
                return lists.clone();
            }
        }
        let lists = Arc::new(Self::build(scene));
        *last = Some((key, lists.clone()));
        lists
    }

    /// Calls `f` for every triangle sharing a vertex position with triangle `id` of `scene`
    /// (the scene the lists were built for), `id` itself included; a triangle touching two of
    /// its vertices comes twice.
    pub fn for_each_neighbour(&self, scene: &Scene, id: u32, mut f: impl FnMut(u32)) {
        for &v in &scene.triangles[id as usize] {
            let w = self.welded[v as usize] as usize;
            let row = self.offsets[w] as usize..self.offsets[w + 1] as usize;
            self.triangles[row].iter().for_each(|&t| f(t));
        }
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        4 * (self.welded.len() + self.offsets.len() + self.triangles.len())
    }
}

/// A 64-bit hash of the scene's positions and triangles (FNV-style over their words).
fn contents_hash(scene: &Scene) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325 ^ (scene.positions.len() as u64) << 1;
    let mut mix = |w: u32| h = (h ^ u64::from(w)).wrapping_mul(0x0000_0100_0000_01b3);
    for p in &scene.positions {
        p.to_array().iter().for_each(|c| mix(c.to_bits()));
    }
    mix(u32::MAX);
    for t in &scene.triangles {
        t.iter().for_each(|&v| mix(v));
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use sightline_core::scene::SceneBuilder;

    /// Two quads side by side, each with its own vertices (the shared edge is duplicated), and
    /// a triangle far away.
    fn scene() -> Scene {
        let mut b = SceneBuilder::new("quads");
        for x0 in [0.0f32, 1.0] {
            let v: Vec<u32> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
                .iter()
                .map(|&(x, y)| b.add_vertex(Vec3::new(x0 + x, y, 0.0)))
                .collect();
            b.add_triangle([v[0], v[1], v[2]]);
            b.add_triangle([v[0], v[2], v[3]]);
        }
        let far = [9.0, 10.0, 11.0].map(|x| b.add_vertex(Vec3::new(x, 5.0, 0.0)));
        b.add_triangle(far);
        b.finish()
    }

    fn neighbours(lists: &VertexNeighbours, scene: &Scene, id: u32) -> Vec<u32> {
        let mut out = Vec::new();
        lists.for_each_neighbour(scene, id, |t| out.push(t));
        out.sort_unstable();
        out.dedup();
        out
    }

    #[test]
    fn triangles_sharing_a_position_are_neighbours_across_duplicated_vertices() {
        let s = scene();
        let lists = VertexNeighbours::build(&s);
        // Triangle 0 = (0,0) (1,0) (1,1): its quad's other half, and both halves of the second
        // quad through (1,0) and (1,1), whose vertices are separate copies.
        assert_eq!(neighbours(&lists, &s, 0), vec![0, 1, 2, 3]);
        // Triangle 1 = (0,0) (1,1) (0,1) touches the second quad at (1,1) only, which its
        // triangle 3 = (1,0) (2,1) (1,1) uses and its triangle 2 does not.
        assert_eq!(neighbours(&lists, &s, 1), vec![0, 1, 3]);
        assert_eq!(neighbours(&lists, &s, 4), vec![4]);
        // 11 vertices, 9 positions (10 offsets), 15 corners.
        assert_eq!(lists.memory_bytes(), 4 * (11 + 10 + 15));
    }

    #[test]
    fn shared_lists_follow_the_scene_contents() {
        let s = scene();
        let a = VertexNeighbours::shared(&s);
        let b = VertexNeighbours::shared(&s.clone());
        assert!(Arc::ptr_eq(&a, &b), "same contents: the same lists");
        let mut moved = s.clone();
        // Weld the far triangle onto the first quad: a different scene, new lists.
        moved.positions[8] = Vec3::new(1.0, 1.0, 0.0);
        let c = VertexNeighbours::shared(&moved);
        assert!(!Arc::ptr_eq(&a, &c));
        assert!(neighbours(&c, &moved, 4).contains(&0));
    }
}
