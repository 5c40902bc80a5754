//! Transports carry whole frames: a UDP datagram is one frame; a byte stream (a serial
//! line, a socket pair in tests) carries COBS-encoded frames delimited by 0x00, so a lost
//! or corrupted byte costs one frame and the receiver resynchronises at the next delimiter.

use std::io::{self, Read, Write};
use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::os::fd::{AsRawFd, RawFd};
use std::time::Duration;

use inchworm_hil_protocol::{cobs, MAX_FRAME};

/// Where a received frame came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Source {
    /// A point-to-point link (a serial line, a socket pair): there is only one peer.
    Line,
    Udp(SocketAddr),
}

impl std::fmt::Display for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Source::Line => f.write_str("the line"),
            Source::Udp(a) => write!(f, "{a}"),
        }
    }
}

/// One frame out, one frame in. `recv` returns `Ok(None)` when nothing arrived in time and
/// `Err(InvalidData)` for bytes that cannot be a frame (the caller counts them as malformed).
pub trait Transport: Send {
    fn send(&mut self, frame: &[u8]) -> io::Result<()>;
    /// Waits up to `timeout` (zero: only what has already arrived).
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>>;
    /// The sender of the frame `recv` returned last.
    fn source(&self) -> Source {
        Source::Line
    }
    /// Where `send` goes from now on: the board points it at the controller whose HELLO
    /// opened the session. A point-to-point link has nowhere else to send.
    fn set_peer(&mut self, _peer: Source) {}
    /// One frame to `to` without changing the peer: a refusal to a sender that holds no
    /// session.
    fn send_to(&mut self, frame: &[u8], _to: Source) -> io::Result<()> {
        self.send(frame)
    }
}

impl<T: Transport + ?Sized> Transport for Box<T> {
    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        (**self).send(frame)
    }
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>> {
        (**self).recv(buf, timeout)
    }
    fn source(&self) -> Source {
        (**self).source()
    }
    fn set_peer(&mut self, peer: Source) {
        (**self).set_peer(peer)
    }
    fn send_to(&mut self, frame: &[u8], to: Source) -> io::Result<()> {
        (**self).send_to(frame, to)
    }
}

/// Blocks until `fd` is readable or `timeout` passes; nanosecond resolution (ppoll), so a
/// 2 ms period is not rounded to whole milliseconds as poll(2) would.
fn wait_readable(fd: RawFd, timeout: Duration) -> io::Result<bool> {
    wait_readable_any(&[Some(fd)], timeout)
}

/// [`wait_readable`] for whichever of `fds` becomes readable first (`None`s are skipped).
fn wait_readable_any(fds: &[Option<RawFd>], timeout: Duration) -> io::Result<bool> {
    let mut pfds = [libc::pollfd { fd: -1, events: libc::POLLIN, revents: 0 }; 2];
    let mut n = 0;
    for fd in fds.iter().flatten().take(pfds.len()) {
        pfds[n].fd = *fd;
        n += 1;
    }
    let ts = libc::timespec {
        tv_sec: timeout.as_secs() as libc::time_t,
        tv_nsec: timeout.subsec_nanos() as libc::c_long,
    };
    loop {
        // SAFETY: `n` valid pollfds, a valid timespec, no signal mask.
        let r = unsafe { libc::ppoll(pfds.as_mut_ptr(), n as libc::nfds_t, &ts, std::ptr::null()) };
        if r >= 0 {
            return Ok(r > 0);
        }
        let e = io::Error::last_os_error();
        if e.kind() != io::ErrorKind::Interrupted {
            return Err(e);
        }
    }
}

/// UDP. The controller side connects to the board and drops datagrams from any other
/// address. The board side binds and hands every datagram up with its [`Source`]: which
/// sender holds the session is the board's decision (docs/hil-protocol.md, "Sessions"), so
/// a stray datagram can never claim the socket.
///
/// The board's session has a socket of its own: once the board names a peer, a second
/// socket on the board's address and port (both with SO_REUSEPORT) is connected to it, and
/// the kernel puts the peer's datagrams there, everyone else's in the first socket. A
/// flood of datagrams from other ports then overfills only the first socket's buffer: with
/// one buffer for all, the kernel dropped the session's DAC frames with the flood's, and a
/// board short of CPU lost 25 periods of them in a row, its watchdog firing on a
/// controller that had sent every one (tests/python/test_hostile_bridge.py, the HELLO
/// flood with both cores busy). The session's socket is read first.
pub struct UdpTransport {
    socket: UdpSocket,
    /// Board side: the socket connected to the peer, where the kernel supports it.
    session: Option<UdpSocket>,
    peer: Option<SocketAddr>,
    /// Connected (controller side): only the peer's datagrams are taken.
    connected: bool,
    from: Option<SocketAddr>,
    foreign: u64,
}

/// A non-blocking UDP socket bound to `local` with SO_REUSEPORT, connected to `peer` if
/// one is given.
fn reuse_port_socket(local: SocketAddr, peer: Option<SocketAddr>) -> io::Result<UdpSocket> {
    use socket2::{Domain, Protocol, Socket, Type};
    let socket = Socket::new(Domain::for_address(local), Type::DGRAM, Some(Protocol::UDP))?;
    socket.set_reuse_port(true)?;
    socket.set_nonblocking(true)?;
    socket.bind(&local.into())?;
    if let Some(peer) = peer {
        socket.connect(&peer.into())?;
    }
    Ok(socket.into())
}

impl UdpTransport {
    pub fn bind(local: impl ToSocketAddrs) -> io::Result<UdpTransport> {
        // Each address in turn, as UdpSocket::bind tries them. SO_REUSEPORT would let a
        // second board bind the port beside this one (the kernel then splits the
        // controllers between them): a plain socket bound first, and closed, claims the
        // port (port 0 a free one), and fails "address in use" where a board has it.
        let mut last = None;
        for addr in local.to_socket_addrs()? {
            let claimed = UdpSocket::bind(addr).and_then(|probe| probe.local_addr());
            match claimed.and_then(|addr| reuse_port_socket(addr, None)) {
                Ok(socket) => {
                    return Ok(UdpTransport {
                        socket,
                        session: None,
                        peer: None,
                        connected: false,
                        from: None,
                        foreign: 0,
                    })
                }
                Err(e) => last = Some(e),
            }
        }
        Err(last.unwrap_or_else(|| {
            io::Error::new(io::ErrorKind::InvalidInput, "the address resolves to nothing")
        }))
    }

    pub fn connect(remote: impl ToSocketAddrs) -> io::Result<UdpTransport> {
        let remote = remote.to_socket_addrs()?.next().ok_or_else(|| {
            io::Error::new(io::ErrorKind::InvalidInput, "the board address resolves to nothing")
        })?;
        let local: SocketAddr = if remote.is_ipv4() {
            SocketAddr::from(([0, 0, 0, 0], 0))
        } else {
            SocketAddr::from(([0u16; 8], 0))
        };
        let socket = UdpSocket::bind(local)?;
        socket.set_nonblocking(true)?;
        Ok(UdpTransport {
            socket,
            session: None,
            peer: Some(remote),
            connected: true,
            from: None,
            foreign: 0,
        })
    }

    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }

    /// Connected side: datagrams dropped because they came from another address than the
    /// board.
    pub fn foreign_datagrams(&self) -> u64 {
        self.foreign
    }

    fn send_datagram(&self, frame: &[u8], to: SocketAddr) -> io::Result<()> {
        let sent = match &self.session {
            // Out of the socket the peer's datagrams come in by, as they would from the
            // first one: the same address and port.
            Some(session) if Some(to) == self.peer => session.send(frame),
            _ => self.socket.send_to(frame, to),
        };
        match sent {
            Ok(_) => Ok(()),
            // A full socket buffer or an ICMP port-unreachable from a peer that is not up
            // yet (or has gone) is a lost frame, which the protocol tolerates; it is not a
            // reason to stop.
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::ConnectionRefused
                ) =>
            {
                Ok(())
            }
            Err(e) => Err(e),
        }
    }
}

impl Transport for UdpTransport {
    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        let Some(peer) = self.peer else {
            return Err(io::Error::new(
                io::ErrorKind::NotConnected,
                "no peer yet: no controller has opened a session",
            ));
        };
        self.send_datagram(frame, peer)
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>> {
        let mut waited = false;
        loop {
            if let Some(session) = &self.session {
                match session.recv(buf) {
                    Ok(n) => {
                        self.from = self.peer;
                        return Ok(Some(n));
                    }
                    // The peer's ICMP port-unreachable (it is not up yet, or gone) is
                    // reported once, ahead of what is queued behind it: read on, or its
                    // DISARM would come after a datagram on the first socket that came later.
                    Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => continue,
                    Err(e) if e.kind() == io::ErrorKind::WouldBlock => {}
                    Err(e) => return Err(e),
                }
            }
            match self.socket.recv_from(buf) {
                Ok((_, from)) if self.connected && Some(from) != self.peer => {
                    self.foreign += 1;
                }
                Ok((n, from)) => {
                    self.from = Some(from);
                    return Ok(Some(n));
                }
                Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => continue,
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                    let fds = [
                        Some(self.socket.as_raw_fd()),
                        self.session.as_ref().map(|s| s.as_raw_fd()),
                    ];
                    if waited || timeout.is_zero() || !wait_readable_any(&fds, timeout)? {
                        return Ok(None);
                    }
                    waited = true;
                }
                Err(e) => return Err(e),
            }
        }
    }

    fn source(&self) -> Source {
        self.from.map_or(Source::Line, Source::Udp)
    }

    fn set_peer(&mut self, peer: Source) {
        let (false, Source::Udp(a)) = (self.connected, peer) else {
            return;
        };
        if self.peer == Some(a) && self.session.is_some() {
            return;
        }
        self.peer = Some(a);
        // Without a socket of its own (a kernel or platform that refuses one) the session
        // shares the first socket, as it did before it had one.
        self.session = self
            .socket
            .local_addr()
            .and_then(|local| reuse_port_socket(local, Some(a)))
            .map_err(|e| log::warn!("the session with {a} shares the board's socket: {e}"))
            .ok();
    }

    fn send_to(&mut self, frame: &[u8], to: Source) -> io::Result<()> {
        match to {
            Source::Udp(a) => self.send_datagram(frame, a),
            Source::Line => self.send(frame),
        }
    }
}

/// COBS frames over a byte stream. The stream must be in non-blocking mode.
pub struct CobsTransport<S> {
    stream: S,
    pending: Vec<u8>,
    encoded: Vec<u8>,
}

/// A frame larger than this between two delimiters is line noise, not a frame.
const MAX_ENCODED: usize = cobs::max_encoded_len(MAX_FRAME) + 1;

impl<S: Read + Write + AsRawFd + Send> CobsTransport<S> {
    pub fn new(stream: S) -> CobsTransport<S> {
        CobsTransport {
            stream,
            pending: Vec::with_capacity(4 * MAX_ENCODED),
            encoded: vec![0; MAX_ENCODED],
        }
    }

    /// Takes one delimited chunk out of `pending`, if a whole one is there.
    fn take_frame(&mut self, buf: &mut [u8]) -> Option<io::Result<usize>> {
        let end = self.pending.iter().position(|&b| b == 0)?;
        let chunk: Vec<u8> = self.pending.drain(..=end).collect();
        let chunk = &chunk[..end];
        if chunk.is_empty() {
            // Back-to-back delimiters: a sender flushing the line; not a frame.
            return self.take_frame(buf);
        }
        Some(
            cobs::decode(chunk, buf)
                .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, format!("COBS: {e}"))),
        )
    }
}

impl<S: Read + Write + AsRawFd + Send> Transport for CobsTransport<S> {
    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        let n = cobs::encode(frame, &mut self.encoded)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e.to_string()))?;
        self.encoded[n] = 0;
        // A leading delimiter closes any partial frame a restarted peer left on the line.
        self.stream.write_all(&[0])?;
        self.stream.write_all(&self.encoded[..=n])
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>> {
        let mut waited = false;
        loop {
            if let Some(r) = self.take_frame(buf) {
                return r.map(Some);
            }
            if self.pending.len() > MAX_ENCODED {
                // No delimiter within a frame's length: drop the noise, keep the link.
                self.pending.clear();
                return Err(io::Error::new(
                    io::ErrorKind::InvalidData,
                    "COBS: no delimiter within a frame's length",
                ));
            }
            let mut chunk = [0u8; 256];
            match self.stream.read(&mut chunk) {
                Ok(0) => {
                    return Err(io::Error::new(
                        io::ErrorKind::UnexpectedEof,
                        "the serial stream closed",
                    ))
                }
                Ok(n) => self.pending.extend_from_slice(&chunk[..n]),
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                    if waited
                        || timeout.is_zero()
                        || !wait_readable(self.stream.as_raw_fd(), timeout)?
                    {
                        return Ok(None);
                    }
                    waited = true;
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
}

/// Opens a serial device raw (8N1, no flow control, no echo) at `baud`, non-blocking.
pub fn open_serial(path: &std::path::Path, baud: u32) -> io::Result<std::fs::File> {
    use std::os::unix::fs::OpenOptionsExt;
    let file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(libc::O_NOCTTY | libc::O_NONBLOCK)
        .open(path)?;
    let speed = match baud {
        115_200 => libc::B115200,
        230_400 => libc::B230400,
        460_800 => libc::B460800,
        921_600 => libc::B921600,
        1_000_000 => libc::B1000000,
        2_000_000 => libc::B2000000,
        other => {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("unsupported baud rate {other}: use 115200, 230400, 460800, 921600, 1000000 or 2000000"),
            ))
        }
    };
    // SAFETY: tcgetattr/tcsetattr on an open descriptor with a zeroed termios they fill.
    unsafe {
        let mut tio: libc::termios = std::mem::zeroed();
        if libc::tcgetattr(file.as_raw_fd(), &mut tio) != 0 {
            return Err(io::Error::last_os_error());
        }
        libc::cfmakeraw(&mut tio);
        libc::cfsetispeed(&mut tio, speed);
        libc::cfsetospeed(&mut tio, speed);
        tio.c_cflag |= libc::CLOCAL | libc::CREAD;
        tio.c_cflag &= !libc::CRTSCTS;
        if libc::tcsetattr(file.as_raw_fd(), libc::TCSANOW, &tio) != 0 {
            return Err(io::Error::last_os_error());
        }
    }
    Ok(file)
}
