//! Ground truth for the photo pipeline, built from derma's own head: a face disc to unwrap,
//! and photos of a known texture rendered from known cameras under varied light, exposure,
//! white balance and vignetting, with landmarks perturbed like a person's clicks.

use crate::error::Result;
use crate::topology::fill_holes;
use derma_core::mesh::TriMesh;
use derma_head::regions::index;
use derma_head::Head;

/// The built-in head's skin without the mouth cavity and eye sockets, the openings closed as a
/// scanner closes them: a disc bounded at the neck, as Tarini et al. 2002 §3.1 assume.
pub fn head_disc(head: &Head) -> Result<TriMesh> {
    let skin = &head.skin;
    let (mi, es) = (
        index("mouth_interior").expect("region"),
        index("eye_sockets").expect("region"),
    );
    let keep: Vec<[u32; 3]> = skin
        .triangles
        .iter()
        .copied()
        .filter(|t| {
            let c = t.map(|i| skin.positions[i as usize]);
            let uv = t.map(|i| skin.uvs[i as usize]);
            let w = head
                .regions
                .weights((c[0] + c[1] + c[2]) / 3.0, (uv[0] + uv[1] + uv[2]) / 3.0);
            w[mi] < 0.5 && w[es] < 0.5
        })
        .collect();
    let cut = TriMesh {
        positions: skin.positions.clone(),
        normals: skin.normals.clone(),
        uvs: Vec::new(),
        triangles: keep,
    };
    Ok(fill_holes(&cut)?.0)
}

/// The front of [`head_disc`]: the face from brow to chin and ear to ear (canonical face
/// coordinates of [`derma_head::Regions::face_coords`]: |x| < 85, −105 < y < 85, frontness > 0.3),
/// its largest connected piece, holes closed — the kind of face mask a scan or a face tracker
/// gives.
pub fn face_disc(head: &Head) -> Result<TriMesh> {
    let disc = head_disc(head)?;
    let keep: Vec<[u32; 3]> = disc
        .triangles
        .iter()
        .copied()
        .filter(|t| {
            let c = t.map(|i| disc.positions[i as usize]);
            let (x, y, front) = head.regions.face_coords((c[0] + c[1] + c[2]) / 3.0);
            x.abs() < 85.0 && y > -105.0 && y < 85.0 && front > 0.3
        })
        .collect();
    let cut = TriMesh {
        positions: disc.positions.clone(),
        normals: disc.normals.clone(),
        uvs: Vec::new(),
        triangles: keep,
    };
    Ok(fill_holes(&largest_component(&cut))?.0)
}

/// The largest edge-connected piece of a mesh (other triangles dropped).
pub fn largest_component(mesh: &TriMesh) -> TriMesh {
    let n = mesh.positions.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    for t in &mesh.triangles {
        for k in 1..3 {
            let (a, b) = (find(&mut parent, t[0]), find(&mut parent, t[k]));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let mut count = std::collections::HashMap::new();
    for t in &mesh.triangles {
        *count.entry(find(&mut parent, t[0])).or_insert(0usize) += 1;
    }
    let best = count.iter().max_by_key(|(k, c)| (**c, std::cmp::Reverse(**k))).map(|(k, _)| *k);
    let mut out = mesh.clone();
    out.triangles.retain(|t| Some(find(&mut parent, t[0])) == best);
    out
}
