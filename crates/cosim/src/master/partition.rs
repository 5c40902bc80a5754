//! A system as its independent subsystems: the connected components of its connection
//! graph (components joined by a component-to-component connection; the system's own
//! connectors join nothing, since a system input is the same table for every component
//! it feeds), grouped into parts of whole subsystems that can run apart: on threads
//! ([`super::parallel`]) or on other machines (`inchworm run --part K/N`).
//!
//! A component's step depends only on its inputs, and a subsystem's inputs come from
//! itself or from the system's input table, so a part run alone steps exactly as it does
//! in the whole system: its recorded columns are the same bits. What a part records is
//! the whole run's columns that it owns, in the whole run's order; [`Split::columns`]
//! says where each column of the whole run is found.

use std::collections::BTreeSet;

use crate::ssp::{Archive, System};
use crate::Error;

/// The connected components of `system`'s component graph, each a list of component
/// indices in SSD order, ordered by their first component.
pub fn subsystems(system: &System) -> Vec<Vec<usize>> {
    let n = system.components.len();
    let index = |name: &str| system.components.iter().position(|c| c.name == name);
    // Union-find with path halving; each root the smallest index of its set.
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for (a, b) in &system.connections {
        let (Some(ea), Some(eb)) = (&a.element, &b.element) else { continue };
        let (Some(i), Some(j)) = (index(ea), index(eb)) else { continue };
        let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
        parent[ri.max(rj)] = ri.min(rj);
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut group_of_root = vec![usize::MAX; n];
    for i in 0..n {
        let r = root(&mut parent, i);
        if group_of_root[r] == usize::MAX {
            group_of_root[r] = groups.len();
            groups.push(Vec::new());
        }
        groups[group_of_root[r]].push(i);
    }
    groups
}

/// `subsystems` (in order) grouped into at most `n` parts of about equal component counts,
/// each part a run of consecutive subsystems, its components in SSD order. Fewer parts
/// than `n` when there are fewer subsystems; never an empty part.
pub fn group(subsystems: &[Vec<usize>], n: usize) -> Vec<Vec<usize>> {
    let total: usize = subsystems.iter().map(Vec::len).sum();
    let n = n.clamp(1, subsystems.len().max(1));
    let mut parts: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut before = 0;
    for s in subsystems {
        // The part whose share of the components the subsystem's middle falls in.
        let middle = 2 * before + s.len();
        let k = (middle * n / (2 * total.max(1))).min(n - 1);
        parts[k].extend(s);
        before += s.len();
    }
    parts.retain(|p| !p.is_empty());
    parts.iter_mut().for_each(|p| p.sort_unstable());
    parts
}

/// A system split into parts, and where each recorded column of the whole run is found.
#[derive(Clone, Debug, PartialEq)]
pub struct Split {
    /// Each part's components, by name, in SSD order.
    pub parts: Vec<Vec<String>>,
    /// The whole run's recorded names, in its order.
    pub record_names: Vec<String>,
    /// Each part's recorded names: the whole run's that it owns, in the whole run's order.
    pub part_records: Vec<Vec<String>>,
    /// For each of `record_names`: (part, index among that part's recorded names).
    pub columns: Vec<(usize, usize)>,
}

impl Split {
    /// The parts of the SSP in `archive` for `jobs` workers, recording `outputs` (empty:
    /// what a whole run records by default).
    pub fn new(archive: &Archive, outputs: &[String], jobs: usize) -> Result<Split, Error> {
        let system = &archive.system;
        let parts = group(&subsystems(system), jobs);
        let part_of_component = |name: &str| {
            let i = system.components.iter().position(|c| c.name == name)?;
            parts.iter().position(|p| p.contains(&i))
        };
        let record_names = if outputs.is_empty() {
            let system_outputs = system
                .connectors
                .iter()
                .filter(|(_, kind)| kind == "output")
                .map(|(n, _)| n.clone())
                .collect();
            archive.default_outputs(system_outputs)?
        } else {
            outputs.to_vec()
        };
        // A column's owner: a system output's driving component, a component variable's
        // component; a system input (the same table everywhere) or a name that is none of
        // these (which the run refuses, as a whole run would) goes to the first part.
        let owner = |name: &str| -> usize {
            let driver = system.connections.iter().find_map(|(a, b)| {
                (b.element.is_none() && b.connector == name).then(|| a.element.clone())?
            });
            let component = driver.or_else(|| name.split_once('.').map(|(c, _)| c.to_string()));
            component.and_then(|c| part_of_component(&c)).unwrap_or(0)
        };
        let mut part_records: Vec<Vec<String>> = vec![Vec::new(); parts.len()];
        let columns = record_names
            .iter()
            .map(|n| {
                let p = owner(n);
                part_records[p].push(n.clone());
                (p, part_records[p].len() - 1)
            })
            .collect();
        let names = |p: &Vec<usize>| p.iter().map(|&i| system.components[i].name.clone()).collect();
        Ok(Split { parts: parts.iter().map(names).collect(), record_names, part_records, columns })
    }

    /// The components of every part but `k`: what part `k` leaves to the others.
    pub fn elsewhere(&self, k: usize) -> BTreeSet<String> {
        self.parts
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != k)
            .flat_map(|(_, p)| p.iter().cloned())
            .collect()
    }
}

/// What part `k` of a system keeps of the SSD: the connections whose component ends are
/// all its own (a connection between a system connector and another part's component is
/// that part's), and the system output connectors among `records`.
pub(super) fn keep_part(system: &mut System, elsewhere: &BTreeSet<String>) {
    let away = |e: &Option<String>| e.as_ref().is_some_and(|c| elsewhere.contains(c));
    system.components.retain(|c| !elsewhere.contains(&c.name));
    system.connections.retain(|(a, b)| !away(&a.element) && !away(&b.element));
    let driven: BTreeSet<String> = system
        .connections
        .iter()
        .filter(|(_, b)| b.element.is_none())
        .map(|(_, b)| b.connector.clone())
        .collect();
    system.connectors.retain(|(n, kind)| kind != "output" || driven.contains(n));
}

/// Whether `name` (`component.variable`) belongs to a component of `elsewhere`.
pub(super) fn is_elsewhere(elsewhere: &BTreeSet<String>, name: &str) -> bool {
    name.split_once('.').is_some_and(|(c, _)| elsewhere.contains(c))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ssp::{Component, End};

    fn system(names: &[&str], links: &[(&str, &str)]) -> System {
        let end = |e: &str| End { element: Some(e.to_string()), connector: "x".into() };
        System {
            components: names
                .iter()
                .map(|n| Component { name: n.to_string(), source: "resources/M.fmu".into() })
                .collect(),
            connections: links.iter().map(|(a, b)| (end(a), end(b))).collect(),
            ..System::default()
        }
    }

    #[test]
    fn subsystems_are_the_connected_components_in_ssd_order() {
        // a-c-e joined through c, b and d alone, f-g; a system connector joins nothing.
        let mut s = system(
            &["a", "b", "c", "d", "e", "f", "g"],
            &[("a", "c"), ("e", "c"), ("g", "f"), ("c", "a")],
        );
        s.connections.push((
            End { element: None, connector: "u".into() },
            End { element: Some("b".into()), connector: "x".into() },
        ));
        s.connections.push((
            End { element: None, connector: "u".into() },
            End { element: Some("d".into()), connector: "x".into() },
        ));
        assert_eq!(subsystems(&s), vec![vec![0, 2, 4], vec![1], vec![3], vec![5, 6]]);
    }

    #[test]
    fn parts_are_whole_subsystems_balanced_by_components() {
        let ten: Vec<Vec<usize>> = (0..10).map(|i| vec![2 * i, 2 * i + 1]).collect();
        let two = group(&ten, 2);
        assert_eq!(two, vec![(0..10).collect::<Vec<_>>(), (10..20).collect()]);
        let three = group(&ten, 3);
        assert_eq!(three.iter().map(Vec::len).collect::<Vec<_>>(), vec![6, 8, 6]);
        // More workers than subsystems: one part each; one subsystem: one part.
        assert_eq!(group(&ten[..2], 8), vec![vec![0, 1], vec![2, 3]]);
        assert_eq!(group(&[vec![0, 1, 2]], 4), vec![vec![0, 1, 2]]);
        // A big subsystem takes a part of its own, no part is empty.
        let lopsided = vec![vec![0], vec![1, 2, 3, 4, 5, 6, 7, 8], vec![9]];
        assert_eq!(group(&lopsided, 3), vec![vec![0], vec![1, 2, 3, 4, 5, 6, 7, 8], vec![9]]);
        assert_eq!(group(&[], 2), Vec::<Vec<usize>>::new());
    }

    #[test]
    fn a_part_keeps_its_own_connections_and_system_outputs() {
        let mut s = system(&["a", "b", "c"], &[("a", "b")]);
        let sys = |c: &str| End { element: None, connector: c.into() };
        let el = |e: &str| End { element: Some(e.into()), connector: "y".into() };
        s.connectors = vec![("u".into(), "input".into()), ("ya".into(), "output".into())];
        s.connectors.push(("yc".into(), "output".into()));
        s.connections.push((sys("u"), el("c")));
        s.connections.push((el("a"), sys("ya")));
        s.connections.push((el("c"), sys("yc")));
        let mut part = s.clone();
        keep_part(&mut part, &BTreeSet::from(["a".to_string(), "b".to_string()]));
        assert_eq!(part.components.len(), 1);
        assert_eq!(part.connections, vec![(sys("u"), el("c")), (el("c"), sys("yc"))]);
        // Every system input stays (the table is the same for all); outputs of c only.
        let kept: Vec<&str> = part.connectors.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(kept, vec!["u", "yc"]);
        assert!(is_elsewhere(&BTreeSet::from(["a".to_string()]), "a.x"));
        assert!(!is_elsewhere(&BTreeSet::from(["a".to_string()]), "ab.x"));
    }
}
