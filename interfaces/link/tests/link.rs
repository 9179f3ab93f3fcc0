//! Two iceoryx2 instances in one process, as two hosts would have them, joined by two
//! Zenoh sessions on the loopback interface: a bridged topic crosses with its wake-up,
//! one not bridged does not, and the control plane carries a request, its reply and a
//! node's end. (The same across real network namespaces: `tests/hosts.rs`.)

use aisle_bus::WaitOutcome;
use aisle_link::testing::{LoopbackPair, loopback_decls};
use aisle_link::{
    ControlClient, ControlServer, HostReply, HostRequest, open_session, zenoh_config,
};
use aisle_messages::topics;
use std::time::Duration;

#[test]
fn a_bridged_topic_crosses_with_its_wake_up_and_no_other_does() {
    let pair = LoopbackPair::new("x", &[topics::ROBOT_STATE.name]);
    let (bus_a, bus_b) = (&pair.a, &pair.b);
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
    let (da, db) = loopback_decls();
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
