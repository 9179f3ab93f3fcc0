//! Two processes' worth of bus in one test process: isolation, schema check, in-place
//! publishing, waiting with a deadline, and cleanup of the instance.

use aisle_bus::{Bus, BusError, Instance, Stamp, WaitOutcome};
use aisle_messages::{NodeKind, TickMode, topics};
use std::path::Path;
use std::time::Duration;

fn instance() -> Instance {
    Instance::unique(Path::new("/tmp/aisle-bus-tests"))
}

/// Joins `inst` from another thread (as another process would) while this thread, the
/// supervisor, keeps its announcement's connections up to date.
fn join_while_serving(
    inst: &Instance,
    info: &aisle_bus::Publisher<aisle_messages::InstanceInfo>,
    kind: NodeKind,
) -> Result<aisle_messages::InstanceInfo, BusError> {
    let inst2 = inst.clone();
    let joiner =
        std::thread::spawn(move || Bus::join(&inst2, kind, Duration::from_secs(2)).map(|(_, i)| i));
    while !joiner.is_finished() {
        info.update_connections().unwrap();
        std::thread::sleep(Duration::from_millis(5));
    }
    joiner.join().unwrap()
}

#[test]
fn a_large_message_arrives_intact_and_the_instance_leaves_nothing() {
    let inst = instance();
    {
        let (sup, announcement) = Bus::create_instance(&inst, 7, TickMode::Lockstep).unwrap();
        let info = join_while_serving(&inst, &announcement, NodeKind::Lidar).unwrap();
        assert_eq!(info.seed, 7);
        let sub = sup.subscriber(topics::POINT_CLOUD).unwrap();
        let mut publ = sup.publisher(topics::POINT_CLOUD).unwrap();
        publ.publish(
            Stamp {
                stamp_ns: 100,
                tick: 1,
                tick_wall_ns: 5,
            },
            |m| {
                m.rows = 31;
                m.cols = 1201;
                m.points[37_230] = [1.0, 2.0, 3.0];
                m.points[0] = [f32::NAN; 3];
            },
        )
        .unwrap();
        let (outcome, sample) = sub
            .wait_for(Duration::from_secs(1), |m| m.header.tick == 1, || {})
            .unwrap();
        assert_eq!(outcome, WaitOutcome::Matched);
        let m = sample.unwrap();
        assert_eq!(
            (m.rows, m.cols, m.header.seq, m.header.stamp_ns),
            (31, 1201, 1, 100)
        );
        assert_eq!(m.header.source, NodeKind::Supervisor.code());
        assert_eq!(m.points[37_230], [1.0, 2.0, 3.0]);
        assert!(m.points[0][0].is_nan());
        assert_eq!(m.points[5], [0.0; 3], "the loan is zero-filled");
        assert!(!inst.shm_files().is_empty());
    }
    inst.remove().unwrap();
    assert!(inst.is_gone());
}

#[test]
fn a_smaller_message_in_a_used_sample_leaves_no_trace_of_the_larger_one() {
    // The publisher clears only what earlier messages wrote into a sample (`extent.rs`):
    // grids shrinking and growing again, through every sample of the pool, must each
    // arrive with zeros past their own cells.
    let inst = instance();
    {
        let (sup, _info) = Bus::create_instance(&inst, 3, TickMode::Lockstep).unwrap();
        let sub = sup.subscriber(topics::LOCAL_MAP).unwrap();
        let mut publ = sup.publisher(topics::LOCAL_MAP).unwrap();
        let sides = [400usize, 30, 200, 7, 400, 1, 90, 0, 300, 12];
        for (tick, &side) in (1u64..).zip(sides.iter().cycle().take(40)) {
            let stamp = Stamp {
                stamp_ns: tick,
                tick,
                tick_wall_ns: 0,
            };
            publ.publish(stamp, |m| {
                m.width = side as u32;
                m.height = side as u32;
                m.version = tick;
                m.cells[..side * side].fill(1 + (tick % 200) as u8);
            })
            .unwrap();
            let (outcome, sample) = sub
                .wait_for(Duration::from_secs(1), |m| m.header.tick == tick, || {})
                .unwrap();
            assert_eq!(outcome, WaitOutcome::Matched);
            let m = sample.unwrap();
            let used = side * side;
            assert_eq!(m.version, tick);
            assert!(m.cells[..used].iter().all(|&c| c == 1 + (tick % 200) as u8));
            let stale = m.cells[used..].iter().position(|&c| c != 0);
            assert_eq!(stale, None, "tick {tick}: a cell past {used} is not zero");
        }
    }
    inst.remove().unwrap();
}

#[test]
fn raw_ports_carry_a_message_as_its_used_part_and_the_rest_arrives_zero() {
    // A raw subscriber hands out the used part (a grid's cells in use, not its 16 MiB
    // capacity); published again as that prefix into samples larger messages dirtied,
    // typed and raw publishes in turn, each arrives with zeros past its own cells.
    let inst = instance();
    {
        let (sup, _info) = Bus::create_instance(&inst, 3, TickMode::Lockstep).unwrap();
        let raw_in = sup
            .raw_subscriber(topics::GLOBAL_MAP.name)
            .unwrap()
            .unwrap();
        let mut typed = sup.publisher(topics::GLOBAL_MAP).unwrap();
        let mut raw_out = sup.raw_publisher(topics::GLOBAL_MAP.name).unwrap().unwrap();
        let sub = sup.subscriber(topics::GLOBAL_MAP).unwrap();
        let header = std::mem::size_of::<aisle_messages::Header>();
        assert_eq!(
            raw_in.message_size(),
            std::mem::size_of::<aisle_messages::GlobalGrid>()
        );
        let sides = [2000usize, 30, 900, 7, 0, 1500];
        for (tick, &side) in (1u64..).zip(sides.iter().cycle().take(18)) {
            let stamp = Stamp {
                stamp_ns: tick,
                tick,
                tick_wall_ns: 0,
            };
            let fill = 1 + (tick % 200) as u8;
            typed
                .publish(stamp, |m| {
                    (m.width, m.height, m.version) = (side as u32, side as u32, tick);
                    m.cells[..side * side].fill(fill);
                })
                .unwrap();
            // The raw publisher's own messages arrive too: wait for this tick's.
            let tick_of = |c: &[u8]| u64::from_ne_bytes(c[16..24].try_into().unwrap());
            let mut copy = Vec::new();
            while copy.is_empty() {
                raw_in
                    .receive_raw(&mut |b| {
                        if tick_of(b) == tick {
                            copy = b.to_vec()
                        }
                    })
                    .unwrap();
            }
            assert_eq!(copy.len(), 96 + side * side, "tick {tick}: the used part");
            // Every other tick goes out again raw, as the supervisor resends state.
            if tick % 2 == 0 {
                while sub.receive().unwrap().is_some() {}
                raw_out.publish_raw(&copy).unwrap();
            }
            let (outcome, sample) = sub
                .wait_for(Duration::from_secs(1), |m| m.header.tick == tick, || {})
                .unwrap();
            assert_eq!(outcome, WaitOutcome::Matched);
            let m = sample.unwrap();
            let used = side * side;
            assert_eq!(m.version, tick);
            assert!(m.cells[..used].iter().all(|&c| c == fill));
            let stale = m.cells[used..].iter().position(|&c| c != 0);
            assert_eq!(stale, None, "tick {tick}: a cell past {used} is not zero");
        }
        assert!(raw_out.publish_raw(&vec![0u8; header - 1]).is_err());
        let too_long = vec![0u8; raw_in.message_size() + 1];
        assert!(raw_out.publish_raw(&too_long).is_err());
    }
    inst.remove().unwrap();
}

#[test]
fn a_wait_without_data_times_out() {
    let inst = instance();
    {
        let (sup, _info) = Bus::create_instance(&inst, 1, TickMode::Lockstep).unwrap();
        let sub = sup.subscriber(topics::POINT_CLOUD).unwrap();
        let (outcome, sample) = sub
            .wait_for(Duration::from_millis(120), |_| true, || {})
            .unwrap();
        assert_eq!(outcome, WaitOutcome::TimedOut);
        assert!(sample.is_none());
    }
    inst.remove().unwrap();
}

#[test]
fn a_process_of_another_schema_is_refused_with_both_hashes() {
    let inst = instance();
    {
        let foreign = aisle_messages::schema_hash() ^ 0xdead_beef;
        let (_sup, announcement) = Bus::announce(&inst, foreign, 1, TickMode::Lockstep).unwrap();
        let err = join_while_serving(&inst, &announcement, NodeKind::Mapper)
            .expect_err("must be refused");
        assert!(matches!(err, BusError::SchemaMismatch { .. }));
        let text = err.to_string();
        assert!(text.contains(&aisle_messages::schema_hash_hex()), "{text}");
        assert!(text.contains(&format!("{foreign:016x}")), "{text}");
    }
    inst.remove().unwrap();
}

#[test]
fn joining_an_instance_without_supervisor_fails_in_bounded_time() {
    let inst = instance();
    inst.claim().unwrap();
    let err = Bus::join(&inst, NodeKind::Lidar, Duration::from_millis(150))
        .err()
        .unwrap();
    assert!(matches!(err, BusError::NoSupervisor { .. }), "{err}");
    inst.remove().unwrap();
}

#[test]
fn joining_an_instance_that_does_not_exist_fails_and_leaves_nothing() {
    let inst = instance();
    let err = Bus::join(&inst, NodeKind::Replay, Duration::from_secs(5))
        .err()
        .unwrap();
    assert!(matches!(err, BusError::NoInstance { .. }), "{err}");
    assert!(err.to_string().contains("does not exist"), "{err}");
    assert!(inst.is_gone(), "{:?}", inst.shm_files());
    // A root without the management segment is no instance either.
    inst.create_root().unwrap();
    let err = Bus::join(&inst, NodeKind::Replay, Duration::from_secs(5))
        .err()
        .unwrap();
    assert!(matches!(err, BusError::NoInstance { .. }), "{err}");
    assert!(inst.shm_files().is_empty());
    inst.remove().unwrap();
}

#[test]
fn no_file_of_an_instance_is_open_to_group_or_others() {
    use std::os::unix::fs::PermissionsExt;
    let inst = instance();
    {
        let (_sup, announcement) = Bus::create_instance(&inst, 1, TickMode::Lockstep).unwrap();
        join_while_serving(&inst, &announcement, NodeKind::Lidar).unwrap();
        let files = inst.shm_files();
        assert!(!files.is_empty());
        for f in files {
            let mode = std::fs::metadata(&f).unwrap().permissions().mode();
            assert_eq!(mode & 0o077, 0, "{} has mode {mode:o}", f.display());
        }
        let root = std::fs::metadata(&inst.root).unwrap().permissions().mode();
        assert_eq!(root & 0o777, 0o700);
    }
    inst.remove().unwrap();
}

#[test]
fn two_instances_do_not_see_each_other() {
    let a = instance();
    let b = instance();
    {
        let (sa, _) = Bus::create_instance(&a, 1, TickMode::Lockstep).unwrap();
        let (sb, _) = Bus::create_instance(&b, 1, TickMode::Lockstep).unwrap();
        let sub_b = sb.subscriber(topics::POINT_CLOUD).unwrap();
        let mut pub_a = sa.publisher(topics::POINT_CLOUD).unwrap();
        pub_a.publish(Stamp::default(), |_| {}).unwrap();
        let (outcome, _) = sub_b
            .wait_for(Duration::from_millis(100), |_| true, || {})
            .unwrap();
        assert_eq!(outcome, WaitOutcome::TimedOut);
    }
    a.remove().unwrap();
    b.remove().unwrap();
}

#[test]
fn a_join_is_refused_when_a_file_of_the_instance_is_open_to_others() {
    use std::os::unix::fs::PermissionsExt;
    let inst = instance();
    {
        let (_sup, announcement) = Bus::create_instance(&inst, 1, TickMode::Lockstep).unwrap();
        // What iceoryx2 would make were the private management segment not found.
        let planted = format!("/dev/shm/{}planted.global_mgmt", inst.prefix);
        std::fs::write(&planted, b"").unwrap();
        std::fs::set_permissions(&planted, std::fs::Permissions::from_mode(0o666)).unwrap();
        let err =
            join_while_serving(&inst, &announcement, NodeKind::Lidar).expect_err("must be refused");
        let text = err.to_string();
        assert!(
            text.contains(&planted) && text.contains("mode 0666"),
            "{text}"
        );
    }
    inst.remove().unwrap();
}
