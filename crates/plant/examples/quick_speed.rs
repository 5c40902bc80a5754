use inchworm_plant::{Dac, Plant, PlantParams};
use std::time::Instant;
fn main() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/reference/plant-check-trace-fia20.csv");
    let rows: Vec<Dac> = std::fs::read_to_string(path).unwrap().lines().skip(1).map(|l| {
        let f: Vec<f64> = l.split(',').take(4).map(|x| x.parse().unwrap()).collect();
        Dac { earth: f[1], nonearth: f[2], extension: f[3] }
    }).collect();
    let t0 = Instant::now();
    let mut plant = Plant::new(PlantParams::fia20()).unwrap();
    let mut times = Vec::new();
    for _ in 0..60 { for d in &rows { let t = Instant::now(); plant.step(*d, 0.002); times.push(t.elapsed().as_secs_f64()); } }
    let total = t0.elapsed().as_secs_f64();
    times.sort_by(|a,b| a.total_cmp(b));
    println!("total {total:.3}s for 60 s: RTF {:.0}; median {:.2} us p99 {:.2} us max {:.2} us; final counts {}", 60.0/total, times[times.len()/2]*1e6, times[times.len()*99/100]*1e6, times.last().unwrap()*1e6, plant.outputs().encoder_counts);
}
