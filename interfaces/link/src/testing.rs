//! Two hosts in one process, for the link's tests and benchmarks: two private iceoryx2
//! instances (as two hosts would have them) joined by two Zenoh sessions on the loopback
//! interface, with chosen topics bridged. Everything is removed on drop.
//!
//! Knows the link's public API only; nothing here is used by a node.

use crate::{Bridge, HostDecl, open_session, zenoh_config};
use aisle_bus::{Bus, HeldService, Instance};
use aisle_messages::TickMode;

/// A free TCP port on the loopback interface (taken from the OS, then released).
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("the loopback interface gives a free port")
}

/// Hosts `a` (listening) and `b` (dialling `a`) on one loopback endpoint, no nodes.
pub fn loopback_decls() -> (HostDecl, HostDecl) {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let decl = |name: &str, listen: Vec<String>, connect: Vec<String>| HostDecl {
        name: name.into(),
        listen,
        connect,
        nodes: vec![],
    };
    (
        decl("a", vec![endpoint.clone()], vec![]),
        decl("b", vec![], vec![endpoint]),
    )
}

/// A private instance under a short root in /tmp, removed on drop.
pub struct Side {
    pub instance: Instance,
}

impl Side {
    pub fn new(tag: &str) -> Side {
        let id = std::process::id();
        let root = std::path::PathBuf::from(format!("/tmp/alt-{id}{tag}"));
        let _ = std::fs::remove_dir_all(&root);
        Side {
            instance: Instance::new(format!("alt{id}{tag}_"), root)
                .expect("a private instance under /tmp"),
        }
    }
}

impl Drop for Side {
    fn drop(&mut self) {
        let _ = self.instance.remove();
        let _ = std::fs::remove_dir_all(&self.instance.root);
    }
}

/// Two hosts with `topics` bridged both ways: publish on [`LoopbackPair::a`], receive on
/// [`LoopbackPair::b`] (or the reverse).
pub struct LoopbackPair {
    // Fields drop in this order: the links, the held services, the buses, the instances.
    _links: [Bridge; 2],
    _held: Vec<HeldService>,
    pub a: Bus,
    pub b: Bus,
    _sides: [Side; 2],
}

impl LoopbackPair {
    /// `tag` keeps the instances of concurrent pairs apart.
    pub fn new(tag: &str, topics: &[&str]) -> LoopbackPair {
        let (da, db) = loopback_decls();
        let sides = [Side::new(&format!("{tag}a")), Side::new(&format!("{tag}b"))];
        let announce = |s: &Side| {
            Bus::announce(&s.instance, 1, 1, TickMode::Lockstep)
                .expect("a bus on a private instance")
                .0
        };
        let (a, b) = (announce(&sides[0]), announce(&sides[1]));
        let mut held = Vec::new();
        for bus in [&a, &b] {
            for t in topics {
                held.extend(bus.hold_service(t).expect("the service is held"));
            }
        }
        let bridged: Vec<String> = topics.iter().map(|t| t.to_string()).collect();
        let link = |host: &HostDecl, side: &Side| {
            let session = open_session(&host.name, zenoh_config(host, "aisle-test").unwrap())
                .expect("a zenoh session on the loopback interface");
            Bridge::start(&host.name, &side.instance, session, bridged.clone(), vec![])
                .expect("the link starts")
        };
        let links = [link(&da, &sides[0]), link(&db, &sides[1])];
        LoopbackPair {
            _links: links,
            _held: held,
            a,
            b,
            _sides: sides,
        }
    }
}
