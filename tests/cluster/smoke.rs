//! The test harness itself: three nats-server processes form a JetStream cluster with a meta
//! leader, and a killed server (the leader) rejoins after a restart on the same ports and store.
//! Needs nothing of cluster mode in physics-mcp, so it checks the harness on its own.

use std::time::{Duration, Instant};

use crate::nats::NatsCluster;

#[test]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
fn three_nats_servers_elect_a_meta_leader_and_a_killed_one_rejoins() {
    let mut nats = NatsCluster::start();
    assert_eq!(nats.urls().split(',').count(), 3, "{}", nats.urls());
    let leader = nats.meta_leader();
    eprintln!("meta leader: {} of {}", nats.name(leader), nats.urls());

    nats.kill9(leader);
    assert_eq!(nats.live_urls().split(',').count(), 2);
    // Two of three keep a quorum: a new meta leader among the survivors.
    let started = Instant::now();
    let next = loop {
        if let Some(l) = nats.meta_leader_now().filter(|&l| l != leader) {
            break l;
        }
        assert!(started.elapsed() < Duration::from_secs(30), "no new meta leader after the old one was killed");
        std::thread::sleep(Duration::from_millis(100));
    };
    eprintln!("new meta leader: {} after {:?}", nats.name(next), started.elapsed());

    // Restarted on its ports and store, it is healthy and agrees on the leader (`restart`
    // waits for both).
    nats.restart(leader);
    assert_eq!(nats.live_urls(), nats.urls());
    eprintln!("meta leader after the restart: {}", nats.name(nats.meta_leader()));
}
