//! Two iceoryx2 instances in one process, as two hosts would have them, joined by two
//! Zenoh sessions on the loopback interface: a bridged topic crosses with its wake-up,
//! one not bridged does not, and the control plane carries a request, its reply and a
//! node's end. (The same across real network namespaces: `tests/hosts.rs`.)

use aisle_bus::WaitOutcome;
use aisle_geometry::GridView;
use aisle_link::testing::{LoopbackPair, loopback_decls};
use aisle_link::{
    ControlClient, ControlServer, HostReply, HostRequest, open_session, zenoh_config,
};
use aisle_messages::{GridMessage, Message, topics};
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

/// A global map crosses as its cells (`aisle_link::trimmed`) and arrives whole: the
/// cells of the map, and zeros past them even where the receiving host's samples held a
/// larger map before.
#[test]
fn maps_of_shrinking_size_arrive_whole() {
    let pair = LoopbackPair::new("m", &[topics::GLOBAL_MAP.name]);
    let mut out = pair.a.publisher(topics::GLOBAL_MAP).unwrap();
    let inp = pair.b.subscriber(topics::GLOBAL_MAP).unwrap();
    let send = |out: &mut aisle_bus::Publisher<_>, (w, h, v): (usize, usize, u8)| {
        let cells = vec![v; w * h];
        let map = GridView::new(0.0, 0.0, 0.1, w, h, &cells).unwrap();
        out.publish(
            aisle_bus::Stamp::default(),
            |m: &mut aisle_messages::GlobalGrid| m.write(0, u64::from(v), &map).unwrap(),
        )
        .unwrap()
    };
    // Until the link has seen both sides, a sample may find nobody on the other one.
    let crossed = (0..100).any(|_| {
        let seq = send(&mut out, (10, 10, 9));
        inp.wait_for(Duration::from_millis(100), |m| m.header().seq == seq, || {})
            .is_ok_and(|(o, _)| o == WaitOutcome::Matched)
    });
    assert!(crossed, "no map crossed within 10 s");
    // Larger maps first, so the receiving host's pool holds their cells.
    for (w, h, v) in [(600, 400, 1), (500, 300, 2), (300, 200, 3), (30, 20, 4)] {
        let seq = send(&mut out, (w, h, v));
        let (outcome, got) = inp
            .wait_for(Duration::from_secs(5), |m| m.header().seq == seq, || {})
            .unwrap();
        assert_eq!(outcome, WaitOutcome::Matched, "map {v} did not cross");
        let m = got.expect("the matched sample");
        assert_eq!(
            (m.width, m.height, m.version),
            (w as u32, h as u32, u64::from(v))
        );
        let cells = m.capacity_cells();
        assert!(cells[..w * h].iter().all(|&c| c == v), "map {v}: its cells");
        assert!(
            cells[w * h..].iter().all(|&c| c == 0),
            "map {v}: zeros past them"
        );
        assert_eq!(m.used_len(), 96 + w * h);
    }
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
