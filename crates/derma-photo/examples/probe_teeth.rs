fn main() {
    let head = derma_head::Head::builtin();
    for name in ["teeth_upper", "teeth_lower"] {
        let p = head.part(name).unwrap();
        let m = &p.mesh;
        let (lo, hi) = m.bounds();
        let (ulo, uhi) = m.uvs.iter().fold(
            (glam::Vec2::splat(9.0), glam::Vec2::splat(-9.0)),
            |(a, b), u| (a.min(*u), b.max(*u)),
        );
        println!(
            "{name}: {} verts {} tris bounds {lo:?} {hi:?} uv {ulo:?} {uhi:?}",
            m.positions.len(),
            m.triangles.len()
        );
        // front teeth: |x|<17, sample uv of frontmost
        let front: Vec<_> = m
            .positions
            .iter()
            .zip(&m.uvs)
            .filter(|(p, _)| p.x.abs() < 17.0 && p.z > hi.z - 8.0)
            .collect();
        let (fa, fb) = front.iter().fold(
            (glam::Vec2::splat(9.0), glam::Vec2::splat(-9.0)),
            |(a, b), (_, u)| (a.min(**u), b.max(**u)),
        );
        println!("  front {} uv {fa:?} {fb:?}", front.len());
    }
}
