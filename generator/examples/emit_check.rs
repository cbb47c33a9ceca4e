use boxforge::emit::*;
fn main() {
    let only: Vec<String> = std::env::args().skip(1).collect();
    for name in boxforge::spec::catalog::names() {
        if !only.is_empty() && !only.iter().any(|o| o == name) {
            continue;
        }
        let d = boxforge::derive::Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap();
        for layout in [Layout::Embedded, Layout::Packed] {
            for variant in [Variant::Fast, Variant::Naive] {
                let t = std::time::Instant::now();
                let e = emit(&d, &EmitOptions { layout, variant, ..Default::default() }).unwrap();
                std::fs::write(format!("/tmp/wgsl/{}", e.file_name), &e.source).unwrap();
                let r = boxforge::validate::validate_wgsl(&e.source, &e.file_name);
                let bf = if r.valid {
                    boxforge::validate::check_branch_free(&r, &[&format!("{name}_eval"), &format!("{name}_eval_grad")])
                        .is_ok()
                } else {
                    false
                };
                let loads = r.function(&format!("{name}_eval")).map(|f| f.total_loads).unwrap_or(0);
                println!(
                    "{:40} valid {} branchfree {} loads {} fetches {} ops {}/{} {} bytes {:?}",
                    e.file_name,
                    r.valid,
                    bf,
                    loads,
                    e.stats.fetches_per_eval,
                    e.stats.ops_eval,
                    e.stats.ops_eval_grad,
                    e.source.len(),
                    t.elapsed()
                );
                if !r.valid {
                    println!("{}", r.error.unwrap_or_default().lines().take(12).collect::<Vec<_>>().join("\n"));
                }
            }
        }
    }
}
