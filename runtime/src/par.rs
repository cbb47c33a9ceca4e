//! Host work spread over every core, for the runtime's slow CPU sides (the
//! exact evaluator in the device checks, the 4D renderer's CPU reference).
//! Its own module so that the renderers and the checks both use it without
//! one importing the other.

/// `f` of every item, in order, on every core (the exact evaluator is the
/// slow side of every device check).
pub fn par_map<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let chunk = items.len().div_ceil(threads).max(1);
    std::thread::scope(|s| {
        let handles: Vec<_> = items
            .chunks(chunk)
            .map(|c| {
                let f = &f;
                s.spawn(move || c.iter().map(f).collect::<Vec<R>>())
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().expect("a worker of par_map panicked")).collect()
    })
}
