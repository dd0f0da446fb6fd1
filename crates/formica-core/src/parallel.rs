//! Work shared over a slice between the calling thread and a world's thread pool, with results
//! that do not depend on how many threads there are: each item is worked on by one call that
//! touches only that item (and scratch space).
//!
//! The calling thread works alongside the pool's threads, which take chunks of items from a
//! shared queue: a pool thread that wakes late (they sleep through the serial parts of a tick)
//! only takes fewer chunks. Handing the whole loop to the pool with `install` left the caller
//! idle and the work waiting on two wake-ups: two threads ran the sensing of 1000 robots only
//! 1.2 times as fast as one.

/// How many workers [`for_each_with`] runs at once: the caller and the pool's threads.
pub(crate) fn workers(pool: Option<&rayon::ThreadPool>) -> usize {
    pool.map_or(1, |p| p.current_num_threads() + 1)
}

/// Runs `f` on every item with its index, `chunk` items at a time per hand-over: on the calling
/// thread, and with a pool on its threads too. Each call touches only its own item, so the order
/// (and the number of threads) does not matter.
pub(crate) fn for_each<T: Send>(
    pool: Option<&rayon::ThreadPool>,
    items: &mut [T],
    chunk: usize,
    f: impl Fn(usize, &mut T) + Sync + Send,
) {
    let mut none = vec![(); workers(pool)];
    for_each_with(pool, items, chunk, &mut none, |i, x, _| f(i, x));
}

/// As [`for_each`], with a working state per worker (`states[k]` for the k-th worker; at least
/// one state, and one per pool thread and the caller to use them all). What a state holds
/// between items must not change any item's result (scratch space).
pub(crate) fn for_each_with<T: Send, S: Send>(
    pool: Option<&rayon::ThreadPool>,
    items: &mut [T],
    chunk: usize,
    states: &mut [S],
    f: impl Fn(usize, &mut T, &mut S) + Sync + Send,
) {
    let chunk = chunk.max(1);
    let workers = workers(pool).min(states.len());
    let (Some(pool), true) = (pool, workers > 1 && items.len() > chunk) else {
        let Some(state) = states.first_mut() else {
            return;
        };
        items
            .iter_mut()
            .enumerate()
            .for_each(|(i, x)| f(i, x, state));
        return;
    };
    let chunks = std::sync::Mutex::new(items.chunks_mut(chunk).enumerate());
    let work = |state: &mut S| loop {
        // A panic in `f` poisons nothing that matters here: the iterator stays valid.
        let next = chunks.lock().unwrap_or_else(|e| e.into_inner()).next();
        let Some((c, part)) = next else { break };
        for (k, x) in part.iter_mut().enumerate() {
            f(c * chunk + k, x, state);
        }
    };
    let work = &work;
    let (mine, theirs) = states[..workers].split_at_mut(1);
    pool.in_place_scope(|s| {
        for state in theirs.iter_mut() {
            s.spawn(move |_| work(state));
        }
        work(&mut mine[0]);
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_item_is_worked_on_once_with_its_index_on_any_number_of_threads() {
        for threads in [0, 1, 3] {
            let pool = (threads > 0).then(|| {
                // A test's pool of at most three threads: building it fails only if the
                // system cannot start a thread, and then the test must fail.
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
            });
            for (n, chunk) in [(0, 4), (1, 4), (5, 1), (37, 4), (200, 16), (9, 0)] {
                let mut items = vec![(0usize, 0u32); n];
                let mut states = vec![0usize; workers(pool.as_ref())];
                for_each_with(pool.as_ref(), &mut items, chunk, &mut states, |i, x, s| {
                    x.0 = i;
                    x.1 += 1;
                    *s += 1;
                });
                assert!(items.iter().enumerate().all(|(i, x)| *x == (i, 1)));
                assert_eq!(states.iter().sum::<usize>(), n);
            }
        }
    }
}
