//! `portcullis-floor IN.glb OUT.glb`: the read+write floor of the benchmarks, reading a .glb and
//! writing it back with the gltf crate alone, the least any tool that reads and writes a level
//! does. It prints the seconds taken. `portcullis bench` runs it as a process of its own next
//! to each conversion, on the system allocator, as a program using only that crate would run
//! (the `portcullis` binary allocates through jemalloc); `cargo bench --bench stages` times
//! the same function in process.

mod round_trip;

fn main() {
    let args: Vec<std::path::PathBuf> = std::env::args_os().skip(1).map(Into::into).collect();
    let [input, out] = args.as_slice() else {
        eprintln!("usage: portcullis-floor IN.glb OUT.glb");
        std::process::exit(2);
    };
    let t = std::time::Instant::now();
    match round_trip::read_write(input, out) {
        Ok(()) => println!("{}", t.elapsed().as_secs_f64()),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    }
}
