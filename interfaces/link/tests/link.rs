//! Two iceoryx2 instances in one process, as two hosts would have them, joined by two
//! Zenoh sessions on the loopback interface: a bridged topic crosses with its wake-up,
//! one not bridged does not, and the control plane carries a request, its reply and a
//! node's end. (The same across real network namespaces: `tests/hosts.rs`.)

use aisle_bus::{Bus, Instance, WaitOutcome};
use aisle_link::{
    Bridge, ControlClient, ControlServer, HostDecl, HostReply, HostRequest, open_session,
    zenoh_config,
};
use aisle_messages::{TickMode, topics};
use std::time::Duration;

/// A free TCP port on the loopback interface (taken from the OS, then released).
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Host `a` listens, host `b` dials it.
fn decls() -> (HostDecl, HostDecl) {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let a = HostDecl {
        name: "a".into(),
        listen: vec![endpoint.clone()],
        connect: vec![],
        nodes: vec![],
    };
    let b = HostDecl {
        name: "b".into(),
        listen: vec![],
        connect: vec![endpoint],
        nodes: vec![],
    };
    (a, b)
}

/// A private instance under a short root in /tmp, removed on drop.
struct Side {
    instance: Instance,
}

impl Side {
    fn new(tag: &str) -> Side {
        let prefix = format!("alt{}{tag}_", std::process::id());
        let root = std::path::PathBuf::from(format!("/tmp/alt-{}{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        Side {
            instance: Instance::new(prefix, root).unwrap(),
        }
    }
}

impl Drop for Side {
    fn drop(&mut self) {
        let _ = self.instance.remove();
        let _ = std::fs::remove_dir_all(&self.instance.root);
    }
}

#[test]
fn a_bridged_topic_crosses_with_its_wake_up_and_no_other_does() {
    let (da, db) = decls();
    let (sa, sb) = (Side::new("a"), Side::new("b"));
    let (bus_a, _info_a) = Bus::announce(&sa.instance, 1, 1, TickMode::Lockstep).unwrap();
    let (bus_b, _info_b) = Bus::announce(&sb.instance, 1, 1, TickMode::Lockstep).unwrap();
    let bridged = vec![topics::ROBOT_STATE.name.to_string()];
    let _held_a = bus_a
        .hold_service(topics::ROBOT_STATE.name)
        .unwrap()
        .unwrap();
    let _held_b = bus_b
        .hold_service(topics::ROBOT_STATE.name)
        .unwrap()
        .unwrap();
    let za = open_session("a", zenoh_config(&da, "aisle-test").unwrap()).unwrap();
    let zb = open_session("b", zenoh_config(&db, "aisle-test").unwrap()).unwrap();
    let _link_a = Bridge::start("a", &sa.instance, za, bridged.clone(), vec![]).unwrap();
    let _link_b = Bridge::start("b", &sb.instance, zb, bridged, vec![]).unwrap();

    let mut state = bus_a.publisher(topics::ROBOT_STATE).unwrap();
    let mut tick = bus_a.publisher(topics::TICK).unwrap();
    let state_in = bus_b.subscriber(topics::ROBOT_STATE).unwrap();
    let tick_in = bus_b.subscriber(topics::TICK).unwrap();
    // Until the link has seen both sides, a sample may find nobody on the other one:
    // publish until one arrives.
    let mut got = None;
    for k in 1..=100u64 {
        state
            .publish(aisle_bus::Stamp::default(), |m| {
                m.pose.x = 1.5;
                m.active_goal_id = k;
            })
            .unwrap();
        tick.publish(aisle_bus::Stamp::default(), |_| {}).unwrap();
        // Woken by the bridged event service, not by the end of the slice.
        let (outcome, sample) = state_in
            .wait_for(Duration::from_millis(100), |_| true, || {})
            .unwrap();
        if outcome == WaitOutcome::Matched {
            got = sample.map(|s| (s.pose.x, s.active_goal_id));
            break;
        }
    }
    let (x, id) = got.expect("a robot state crossed within 10 s");
    assert_eq!(x, 1.5);
    assert!(id >= 1);
    assert!(
        tick_in.receive().unwrap().is_none(),
        "the tick is not bridged"
    );
}

#[test]
fn a_request_gets_its_reply_and_a_nodes_end_is_heard() {
    let (da, db) = decls();
    let za = open_session("a", zenoh_config(&da, "aisle-test").unwrap()).unwrap();
    let zb = open_session("b", zenoh_config(&db, "aisle-test").unwrap()).unwrap();
    let server = ControlServer::declare(&zb, "b").unwrap();
    let client = ControlClient::new(&za).unwrap();
    let serve = std::thread::spawn(move || {
        let pending = loop {
            if let Some(p) = server.next(Duration::from_millis(50)) {
                break p;
            }
        };
        let request = pending.request.clone();
        pending.reply(&HostReply::Refused("not today".into()));
        server.exited("lidar", 9);
        request
    });
    let kill = HostRequest::Kill {
        node: "lidar".into(),
    };
    let reply = client.request("b", &kill, Duration::from_secs(10)).unwrap();
    assert_eq!(reply, HostReply::Refused("not today".into()));
    assert_eq!(serve.join().unwrap(), Ok(kill));
    let mut exit = None;
    for _ in 0..200 {
        exit = client.next_exit();
        if exit.is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(25));
    }
    let exit = exit.expect("the end of lidar was reported");
    assert_eq!(
        (exit.host.as_str(), exit.node.as_str(), exit.status),
        ("b", "lidar", 9)
    );
    // Nobody serves host `c`: the request says so instead of waiting forever.
    let none = client.request("c", &HostRequest::Stop, Duration::from_millis(600));
    assert!(
        none.unwrap_err()
            .to_string()
            .contains("aisle host --name c")
    );
}
