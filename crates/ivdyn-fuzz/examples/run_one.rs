//! Runs one fuzz target on one input file (a cargo-fuzz artifact, a smoke-test crash):
//! `cargo run -p ivdyn-fuzz --example run_one -- mcap path/to/input`.

fn main() {
    let mut args = std::env::args().skip(1);
    let (target, path) = (args.next().expect("target"), args.next().expect("input file"));
    let data = std::fs::read(&path).expect("readable input");
    ivdyn_fuzz::run(&target, &data);
    ivdyn_fuzz::remove_scratch();
    println!("{target}: {path} ({} bytes) returned", data.len());
}
