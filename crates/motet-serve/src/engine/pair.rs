//! Pairing a server's nodes from its page: the devices on the server's own
//! links are paired as `motet nodes pair` pairs them (each alone on its
//! link; [`motet_net::pairing`]), the pairing file is written beside the
//! machine file, and the server's runs go on with the nodes at their new
//! addresses.

use super::LinkedNodes;
use motet_host::Machine;
use motet_net::pairing::{pair_machine, Ask, PairError};
use motet_net::pairing_file::PairingFileError;
use motet_net::session::{NodeAddr, Session, SessionError};
use motet_net::NetRun;
use motet_trajectory::Point;
use std::path::PathBuf;

/// Why the nodes could not be paired.
#[derive(Debug, thiserror::Error)]
pub enum PairRefusal {
    /// The nodes are simulated in this process: there is no link and no
    /// device to pair.
    #[error("nothing to pair: the nodes are simulated in this server (`--nodes sim`); pairing is for node processes or boards (`motet serve MACHINE --nodes spawn` or `--nodes paired`)")]
    Simulated,
    /// The server was not told where the machine file is, so it cannot
    /// write the pairing file beside it.
    #[error("this server has no machine file to write the pairing file beside")]
    NoFile,
    /// Pairing failed; where it failed before any address changed (every
    /// link is looked at first), nothing changed.
    #[error("{0}")]
    Pair(#[from] PairError),
    /// The pairing file could not be written (the nodes have their new
    /// addresses: pairing again writes it).
    #[error("{0}")]
    File(#[from] PairingFileError),
    /// The nodes could not be reached again at their addresses.
    #[error("the nodes could not be reached after pairing: {0}")]
    Reach(#[from] SessionError),
}

/// What pairing did: one line per node, and the pairing file written.
#[derive(Clone, Debug)]
pub struct PairOutcome {
    /// What was done, node by node.
    pub lines: Vec<String>,
    /// The pairing file.
    pub file: PathBuf,
}

impl LinkedNodes {
    /// Pairs the devices on this server's links with the machine's nodes,
    /// writes the pairing file and, where an address changed, connects to
    /// them again; the machine rests at `at`.
    pub(super) fn pair_here(
        &mut self,
        machine: &Machine,
        at: Point,
    ) -> Result<PairOutcome, PairRefusal> {
        let path = self.pairing.clone().ok_or(PairRefusal::NoFile)?;
        let links: Vec<(String, String)> = self
            .session
            .nodes
            .iter()
            .map(|n| (n.name.clone(), n.link.clone()))
            .collect();
        let mut lines = Vec::new();
        // The run's links stay open meanwhile: nothing polls them while the
        // session is held, and a refusal leaves the server as it was.
        let file = pair_machine(machine, &links, Ask::Alone, &mut |l| lines.push(l))?;
        file.save(&path)?;
        let nodes: Vec<NodeAddr> = machine
            .nodes
            .iter()
            .filter_map(|spec| {
                file.nodes.get(&spec.name).map(|p| NodeAddr {
                    name: spec.name.clone(),
                    link: p.link.clone(),
                    address: p.address,
                })
            })
            .collect();
        if nodes == self.session.nodes {
            // Every node kept its address (pairing gives them in the same
            // order as `motet nodes pair` and `--nodes spawn`): the run's
            // links, and the clocks they know, go on as they were.
            return Ok(PairOutcome { lines, file: path });
        }
        drop(self.run.take_peers());
        let mut s = Session::attach(machine, &nodes, &motet_net::clock::wall())?;
        let peers = std::mem::take(&mut s.peers);
        self.session.nodes = s.nodes;
        self.session.infos = s.infos;
        self.run = NetRun::new(machine, Vec::new(), peers, at, self.cfg, None);
        if let Some(c) = self.clock {
            self.run.stamp_arrivals(c);
        }
        Ok(PairOutcome { lines, file: path })
    }
}
