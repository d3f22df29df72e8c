use kami::systems::hair_bsdf::*;
fn main() {
    let p = HairParams { eumelanin: 0.7263852721410828, pheomelanin: 0.0, ..Default::default() };
    let b = p.bsdf();
    for arg in std::env::args().skip(1) {
        let v: Vec<f64> = arg.split(',').map(|x| x.parse().unwrap()).collect();
        let a = Angles::new([v[0], v[1], v[2]], [v[3], v[4], v[5]], [v[6], v[7], v[8]]);
        let s = b.radiance(&a);
        println!("S {:.5} {:.5} {:.5}  (x pi = {:.4} {:.4} {:.4})", s[0], s[1], s[2], s[0]*3.14159, s[1]*3.14159, s[2]*3.14159);
    }
}
