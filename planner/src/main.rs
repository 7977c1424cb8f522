//! `cellsar-planner`: command-line front end of the planner library.

fn main() {
    println!("cellsar-planner");
}
