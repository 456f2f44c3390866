//! Strongly connected components of a directed graph on `0..n`: the check's dead ends and the
//! flood PVS (reachability is the same for every node of a component) both need them.

/// Strongly connected components (Tarjan's algorithm, iterative): a component id per node.
/// Ids are in reverse topological order: every component reachable from component `k` has a
/// smaller id, so a pass in increasing id order sees what a component reaches before it.
pub fn components(n: usize, adj: &[Vec<usize>]) -> Vec<usize> {
    const NONE: usize = usize::MAX;
    let mut index = vec![NONE; n];
    let mut low = vec![0; n];
    let mut on_stack = vec![false; n];
    let mut stack = Vec::new();
    let mut comp = vec![NONE; n];
    let mut next_index = 0;
    let mut next_comp = 0;
    for start in 0..n {
        if index[start] != NONE {
            continue;
        }
        // (cell, next neighbour to visit)
        let mut work = vec![(start, 0usize)];
        index[start] = next_index;
        low[start] = next_index;
        next_index += 1;
        stack.push(start);
        on_stack[start] = true;
        while let Some(&mut (v, ref mut k)) = work.last_mut() {
            if *k < adj[v].len() {
                let w = adj[v][*k];
                *k += 1;
                if index[w] == NONE {
                    index[w] = next_index;
                    low[w] = next_index;
                    next_index += 1;
                    stack.push(w);
                    on_stack[w] = true;
                    work.push((w, 0));
                } else if on_stack[w] {
                    low[v] = low[v].min(index[w]);
                }
                continue;
            }
            work.pop();
            if let Some(&(u, _)) = work.last() {
                low[u] = low[u].min(low[v]);
            }
            if low[v] == index[v] {
                while let Some(w) = stack.pop() {
                    on_stack[w] = false;
                    comp[w] = next_comp;
                    if w == v {
                        break;
                    }
                }
                next_comp += 1;
            }
        }
    }
    comp
}

#[cfg(test)]
mod tests {
    use super::components;

    #[test]
    fn tarjan_finds_cycles_and_singletons() {
        // 0 <-> 1 -> 2 -> 3 -> 2
        let adj = vec![vec![1], vec![0, 2], vec![3], vec![2]];
        let c = components(4, &adj);
        assert_eq!(c[0], c[1]);
        assert_eq!(c[2], c[3]);
        assert_ne!(c[0], c[2]);
        // {2, 3} is reached from {0, 1}: a smaller id.
        assert!(c[2] < c[0]);
    }
}
