use djkr::dynamics::{Event, Observer, Sample};
struct O(usize);
impl Observer for O {
    fn sample(&mut self, _s: &Sample) -> bool {
        self.0 < 100
    }
    fn event(&mut self, e: &Event) {
        self.0 += 1;
        if self.0 < 12 || self.0 % 1000000 == 0 {
            println!(
                "{:?} t={:e} a={:e} delta={:e} v={:e} F={:e}",
                e.kind, e.time, e.state.a, e.state.delta, e.state.v_s, e.state.force
            );
        }
        if self.0 > 3_000_000 {
            std::process::exit(0);
        }
    }
}
fn main() {
    let p = std::env::args().nth(1).unwrap();
    let mut s = djkr::scenario::parse::load_scenario(std::path::Path::new(&p)).unwrap();
    s.solver.max_steps = 20000;
    s.solver.max_wall_s = 0.2;
    println!("{:?}", s.simulate(&mut O(0)).map(|r| r.events.len()));
}
