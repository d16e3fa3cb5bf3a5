use phonation::validation::taylor_green::TaylorGreenCase;
use phonation::fluid::VelocitySetKind;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(32);
    let dim3 = args.get(2).map(|s| s == "3").unwrap_or(false);
    let mut c = TaylorGreenCase::new(if dim3 { VelocitySetKind::D3q39 } else { VelocitySetKind::D2q21 }, n);
    if let Some(dt) = args.get(3) { c.dt = Some(dt.parse().unwrap()); }
    if let Some(tau) = args.get(4) { c.tau = Some(tau.parse().unwrap()); }
    if let Some(nu) = args.get(5) { c.nu = nu.parse().unwrap(); }
    let r = c.run();
    println!("{:?}", r);
}
