//! `motet run --nodes spawn --bus BUS`: the multicast group the spawned
//! nodes and the host share.

use anyhow::{bail, Context, Result};

/// The multicast group `--bus BUS` puts spawned nodes on: `udp` is a new
/// group on this computer's loopback (a free port of its own, so runs side
/// by side do not meet), or a `udp-group:` spec as given.
pub fn bus_group(bus: &str) -> Result<String> {
    if bus == "udp" {
        let port = motet_link::udp_group::free_port().context("no free UDP port for the group")?;
        return Ok(format!(
            "udp-group:{}:{port}@127.0.0.1",
            motet_net::loopback::LOOPBACK_GROUP
        ));
    }
    match motet_link::LinkSpec::parse(bus) {
        Ok(spec @ motet_link::LinkSpec::UdpGroup { .. }) => Ok(spec.to_string()),
        _ => bail!("--bus {bus:?}: expected `udp` or `udp-group:GROUP:PORT[@IFACE]`"),
    }
}
