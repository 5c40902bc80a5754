//! What a board is started with: its period, watchdog, pacing and takeover limits, and
//! the `--allow` list of the senders it hears.

use std::net::{IpAddr, SocketAddr};
use std::time::Duration;

use crate::OverrunPolicy;

#[derive(Clone, Copy, Debug)]
pub struct BoardConfig {
    pub period: Duration,
    pub watchdog_periods: u32,
    pub lockstep: bool,
    /// Lock-step: wall-clock periods without any valid frame before the link counts as
    /// dead. Both modes: how long a controller's answered HELLO waits for its ARM (the
    /// handshake window).
    pub dead_link_periods: u32,
    pub overrun: OverrunPolicy,
    /// Re-initialise the mechanism when a new session opens (test rigs only: hardware
    /// keeps its state from one controller to the next).
    pub fresh_plant_per_session: bool,
}

impl Default for BoardConfig {
    fn default() -> Self {
        BoardConfig {
            period: crate::PERIOD,
            watchdog_periods: inchworm_hil_protocol::DEFAULT_WATCHDOG_PERIODS,
            lockstep: false,
            dead_link_periods: inchworm_hil_protocol::LOCKSTEP_DEAD_LINK_PERIODS,
            overrun: OverrunPolicy::Soft,
            fresh_plant_per_session: false,
        }
    }
}

/// One `--allow` entry: an exact address, or a host with any port.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Allow {
    Addr(SocketAddr),
    Host(IpAddr),
}

impl std::str::FromStr for Allow {
    type Err = String;
    fn from_str(s: &str) -> Result<Allow, String> {
        if let Ok(a) = s.parse::<SocketAddr>() {
            return Ok(Allow::Addr(a));
        }
        s.parse::<IpAddr>().map(Allow::Host).map_err(|_| {
            format!(
                "--allow {}: expected an IP address (any port) or IP:PORT, e.g. 127.0.0.1 or 192.168.1.5:40000",
                crate::quoted(s)
            )
        })
    }
}

impl Allow {
    pub fn admits(&self, a: &SocketAddr) -> bool {
        match self {
            Allow::Addr(x) => x == a,
            Allow::Host(ip) => *ip == a.ip(),
        }
    }
}
