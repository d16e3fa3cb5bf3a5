use phonation::fluid::{GasModel, VelocitySetKind::*};
use phonation::validation::*;
fn main() {
    let what = std::env::args().nth(1).unwrap_or_default();
    match what.as_str() {
        "sound" => {
            for (s, g) in [(D2q21, GasModel::Monatomic), (D3q39, GasModel::Monatomic), (D2q21, GasModel::Diatomic), (D3q39, GasModel::Diatomic)] {
                println!("{:?}", sound::sound_speed(s, g, 64));
            }
        }
        "sod" => {
            let mut c = sod::SodCase::new(D2q21, GasModel::Monatomic);
            if let Some(s) = std::env::args().nth(2) { c.scale = s.parse().unwrap(); }
            if let Some(s) = std::env::args().nth(3) { c.nu = s.parse().unwrap(); }
            if let Some(s) = std::env::args().nth(4) { c.gas = if s == "di" { GasModel::Diatomic } else { GasModel::Monatomic }; }
            println!("{:#?}", c.run());
        }
        _ => {}
    }
}
