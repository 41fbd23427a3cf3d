//! Who is connected to the preview, and who is shed when too many are.
//!
//! At most [`PER_CLIENT`] connections per client address and [`MAX_CONNECTIONS`] in all. A
//! newcomer is never turned away: when its address already holds [`PER_CLIENT`] connections,
//! the oldest of them is shed; when the server holds [`MAX_CONNECTIONS`], the oldest connection
//! of the address holding the most is. Of those, a connection still sending its request is shed
//! before one being answered. Shedding shuts the socket down, so its thread's read or
//! write fails at once and the thread ends. A client that opens connections and trickles bytes
//! into them (or stops reading) thus only ever sheds its own, and a page behind the same address
//! (through an SSH tunnel every viewer is 127.0.0.1) still gets in: each of its requests is
//! answered in milliseconds, long before [`PER_CLIENT`] newer connections arrive. The request
//! and response deadlines ([`super::http`]) bound how long anyone holds a connection anyway.

use std::io;
use std::net::{IpAddr, Shutdown, TcpStream};
use std::sync::{Arc, Mutex, PoisonError};

/// Connections one client address may hold; a browser opens up to 6 to one host.
pub const PER_CLIENT: usize = 8;
/// Connections in all (one thread each).
pub const MAX_CONNECTIONS: usize = 32;

/// The open connections, with a handle to shut each down.
#[derive(Debug)]
pub struct Clients {
    table: Mutex<Table<TcpStream>>,
}

/// An admitted connection; it leaves the table when dropped.
#[derive(Debug)]
pub struct Ticket {
    clients: Arc<Clients>,
    id: u64,
}

impl Clients {
    pub fn new() -> Arc<Self> {
        Arc::new(Clients {
            table: Mutex::new(Table::new()),
        })
    }

    /// Admits `stream` from `ip`, shedding another connection if a limit is reached.
    pub fn admit(self: &Arc<Self>, stream: &TcpStream, ip: IpAddr) -> io::Result<Ticket> {
        let handle = stream.try_clone()?;
        let (id, shed) = self
            .table
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .admit(ip, handle);
        if let Some(shed) = shed {
            log::debug!("preview: shedding a connection from {ip} for a newer one");
            // Already closed by its client, perhaps: nothing more to do then.
            let _ = shed.shutdown(Shutdown::Both);
        }
        Ok(Ticket {
            clients: Arc::clone(self),
            id,
        })
    }
}

impl Ticket {
    /// Its request was read: it is shed only after the ones still sending theirs.
    pub fn answering(&self) {
        self.clients
            .table
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .answering(self.id);
    }
}

impl Drop for Ticket {
    fn drop(&mut self) {
        self.clients
            .table
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .leave(self.id);
    }
}

/// One open connection.
#[derive(Debug)]
struct Entry<H> {
    id: u64,
    ip: IpAddr,
    /// Its request was read and it is being answered.
    answering: bool,
    handle: H,
}

/// The open connections, oldest first; `H` shuts one down (a socket; `()` in the tests).
#[derive(Debug)]
struct Table<H> {
    next_id: u64,
    open: Vec<Entry<H>>,
}

impl<H> Table<H> {
    fn new() -> Self {
        Table {
            next_id: 0,
            open: Vec::with_capacity(MAX_CONNECTIONS),
        }
    }

    /// Adds a connection from `ip`: its id, and the handle of the connection shed for it.
    /// One is enough: the limits held before this one came.
    fn admit(&mut self, ip: IpAddr, handle: H) -> (u64, Option<H>) {
        let shed = self.victim(ip).map(|at| self.open.remove(at).handle);
        let id = self.next_id;
        self.next_id += 1;
        self.open.push(Entry {
            id,
            ip,
            answering: false,
            handle,
        });
        (id, shed)
    }

    /// Removes a connection that ended (nothing if it was shed).
    fn leave(&mut self, id: u64) {
        self.open.retain(|e| e.id != id);
    }

    fn answering(&mut self, id: u64) {
        if let Some(e) = self.open.iter_mut().find(|e| e.id == id) {
            e.answering = true;
        }
    }

    fn count(&self, ip: IpAddr) -> usize {
        self.open.iter().filter(|e| e.ip == ip).count()
    }

    /// Where the connection to shed for a newcomer from `ip` is, if a limit is reached.
    fn victim(&self, ip: IpAddr) -> Option<usize> {
        let from = if self.count(ip) >= PER_CLIENT {
            ip
        } else if self.open.len() >= MAX_CONNECTIONS {
            self.busiest()?
        } else {
            return None;
        };
        self.open
            .iter()
            .position(|e| e.ip == from && !e.answering)
            .or_else(|| self.open.iter().position(|e| e.ip == from))
    }

    /// The address holding the most connections; of equals, the one with the oldest.
    fn busiest(&self) -> Option<IpAddr> {
        let mut best: Option<(usize, IpAddr)> = None;
        for e in &self.open {
            let n = self.count(e.ip);
            if best.is_none_or(|(most, _)| n > most) {
                best = Some((n, e.ip));
            }
        }
        best.map(|(_, ip)| ip)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::Ipv4Addr;

    fn ip(n: u8) -> IpAddr {
        IpAddr::V4(Ipv4Addr::new(10, 0, 0, n))
    }

    /// Admits one connection from `ip(n)` labelled `label`; the label of the one shed.
    fn admit(table: &mut Table<u32>, n: u8, label: u32) -> Option<u32> {
        table.admit(ip(n), label).1
    }

    #[test]
    fn one_address_sheds_only_its_own_oldest() {
        let mut table = Table::new();
        for label in 0..PER_CLIENT as u32 {
            assert_eq!(admit(&mut table, 1, label), None);
        }
        assert_eq!(admit(&mut table, 2, 100), None);
        // Address 1 is at its limit: its newcomers shed its oldest, in order.
        assert_eq!(admit(&mut table, 1, 50), Some(0));
        assert_eq!(admit(&mut table, 1, 51), Some(1));
        assert_eq!(table.count(ip(1)), PER_CLIENT);
        assert_eq!(table.count(ip(2)), 1);
    }

    #[test]
    fn connections_still_sending_their_request_go_before_ones_being_answered() {
        let mut table = Table::new();
        let ids: Vec<u64> = (0..PER_CLIENT as u32)
            .map(|label| table.admit(ip(1), label).0)
            .collect();
        table.answering(ids[0]);
        table.answering(ids[2]);
        assert_eq!(admit(&mut table, 1, 100), Some(1));
        assert_eq!(admit(&mut table, 1, 101), Some(3));
        // All the pending ones gone, the oldest answered one is next.
        for label in [4, 5, 6, 7, 100, 101] {
            assert_eq!(admit(&mut table, 1, 200 + label), Some(label));
        }
        for id in table.open.iter().map(|e| e.id).collect::<Vec<_>>() {
            table.answering(id);
        }
        assert_eq!(admit(&mut table, 1, 300), Some(0));
    }

    #[test]
    fn a_full_server_sheds_the_oldest_of_the_busiest_address() {
        let mut table = Table::new();
        let mut label = 0;
        // Four addresses fill the table: 1 holds the most (all of them its oldest).
        for (n, count) in [(1, PER_CLIENT), (2, 7), (3, 8), (4, 8), (5, 1)] {
            for _ in 0..count {
                assert_eq!(admit(&mut table, n, label), None);
                label += 1;
            }
        }
        assert_eq!(table.open.len(), MAX_CONNECTIONS);
        // A newcomer from a sixth address: address 1 has 8, as many as 3 and 4, and the oldest.
        assert_eq!(admit(&mut table, 6, 1000), Some(0));
        // Now 3 and 4 hold the most; 3's oldest goes.
        assert_eq!(admit(&mut table, 7, 1001), Some(15));
        assert_eq!(table.open.len(), MAX_CONNECTIONS);
        // The lone client of address 5 was never touched.
        assert_eq!(table.count(ip(5)), 1);
    }

    #[test]
    fn ended_connections_leave_and_shed_ones_are_not_removed_twice() {
        let mut table = Table::new();
        let (first, _) = table.admit(ip(1), ());
        let (second, _) = table.admit(ip(1), ());
        table.leave(first);
        table.leave(first);
        assert_eq!(table.open.len(), 1);
        table.leave(second);
        assert!(table.open.is_empty());
    }
}
