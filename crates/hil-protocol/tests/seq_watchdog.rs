//! Sequence tracking with wrap-around, and the board watchdog / safe state.

use inchworm_hil_protocol::*;

#[test]
fn seq_distance_wraps() {
    assert_eq!(seq_distance(65535, 0), 1);
    assert_eq!(seq_distance(0, 65535), -1);
    assert_eq!(seq_distance(65530, 4), 10);
    assert_eq!(seq_distance(4, 65530), -10);
    assert_eq!(seq_distance(7, 7), 0);
    assert_eq!(seq_distance(0, 32767), 32767);
    assert_eq!(seq_distance(0, 32768), -32768);
}

#[test]
fn tracker_next_across_wrap() {
    let mut t = SeqTracker::new();
    assert_eq!(t.last(), None);
    assert_eq!(t.accept(65533), SeqVerdict::First);
    for s in [65534u16, 65535, 0, 1, 2] {
        assert_eq!(t.accept(s), SeqVerdict::Next, "seq {s}");
        assert_eq!(t.last(), Some(s));
    }
}

#[test]
fn tracker_gaps_including_across_wrap() {
    let mut t = SeqTracker::new();
    t.accept(10);
    assert_eq!(t.accept(12), SeqVerdict::Gap { missing: 1 });
    assert_eq!(t.last(), Some(12));
    let mut t = SeqTracker::new();
    t.accept(65533);
    assert_eq!(t.accept(2), SeqVerdict::Gap { missing: 4 }); // 65534, 65535, 0, 1 lost
    assert_eq!(t.last(), Some(2));
    assert_eq!(t.accept(3), SeqVerdict::Next);
    let mut t = SeqTracker::new();
    t.accept(0);
    assert_eq!(t.accept(32767), SeqVerdict::Gap { missing: 32766 });
}

#[test]
fn tracker_duplicates_and_stale_do_not_advance() {
    let mut t = SeqTracker::new();
    t.accept(100);
    assert_eq!(t.accept(100), SeqVerdict::Duplicate);
    assert_eq!(t.accept(99), SeqVerdict::Stale { behind: 1 });
    assert_eq!(t.accept(50), SeqVerdict::Stale { behind: 50 });
    assert_eq!(t.last(), Some(100));
    assert_eq!(t.accept(101), SeqVerdict::Next);
    // Reordered pair: 103 before 102.
    assert_eq!(t.accept(103), SeqVerdict::Gap { missing: 1 });
    assert_eq!(t.accept(102), SeqVerdict::Stale { behind: 1 });
    assert_eq!(t.accept(104), SeqVerdict::Next);
    // Stale across the wrap.
    let mut t = SeqTracker::new();
    t.accept(1);
    assert_eq!(t.accept(65535), SeqVerdict::Stale { behind: 2 });
    assert_eq!(t.accept(1), SeqVerdict::Duplicate);
    // Exactly half the circle away is treated as stale, not as a 32767-frame gap.
    assert_eq!(t.accept(32769), SeqVerdict::Stale { behind: 32768 });
    assert_eq!(t.last(), Some(1));
}

#[test]
fn tracker_reset() {
    let mut t = SeqTracker::default();
    t.accept(5);
    t.reset();
    assert_eq!(t.last(), None);
    assert_eq!(t.accept(2), SeqVerdict::First);
}

const REQ: [u16; 3] = [100, 200, 300];

#[test]
fn watchdog_starts_disarmed_and_outputs_safe_codes() {
    let mut w = Watchdog::new(DEFAULT_WATCHDOG_PERIODS);
    assert_eq!(w.state(), BoardState::Disarmed);
    assert_eq!(w.output(REQ), SAFE_CODES);
    assert_eq!(w.status_bits(), 0);
    // Silence while disarmed never trips.
    for _ in 0..100 {
        assert_eq!(w.period_elapsed(), None);
    }
    assert_eq!(w.state(), BoardState::Disarmed);
    w.arm();
    assert_eq!(w.state(), BoardState::Armed);
    assert_eq!(w.output(REQ), REQ);
    assert_eq!(w.status_bits(), status::ARMED);
}

#[test]
fn watchdog_trips_after_exactly_n_silent_periods() {
    for n in 1..=6u32 {
        let mut w = Watchdog::new(n);
        w.arm();
        for k in 1..n {
            assert_eq!(w.period_elapsed(), None, "limit {n}, period {k}");
            assert_eq!(w.missed(), k);
            assert_eq!(w.state(), BoardState::Armed);
            assert_eq!(w.output(REQ), REQ);
        }
        let f = Fault { reason: FaultReason::Silence, detail: n };
        assert_eq!(w.period_elapsed(), Some(f), "limit {n}");
        assert_eq!(w.state(), BoardState::Safe(f));
        assert_eq!(w.output(REQ), SAFE_CODES);
        assert_eq!(w.status_bits(), status::SAFE);
        // Reported once only.
        assert_eq!(w.period_elapsed(), None);
        assert_eq!(w.state(), BoardState::Safe(f));
    }
}

#[test]
fn watchdog_limit_zero_is_clamped_to_one() {
    let mut w = Watchdog::new(0);
    w.arm();
    w.frame_received();
    assert_eq!(w.period_elapsed(), None);
    assert!(w.period_elapsed().is_some());
}

#[test]
fn a_frame_resets_the_count() {
    let mut w = Watchdog::new(3);
    w.arm();
    for _ in 0..50 {
        assert_eq!(w.period_elapsed(), None);
        assert_eq!(w.period_elapsed(), None);
        assert_eq!(w.missed(), 2);
        w.frame_received();
        assert_eq!(w.missed(), 0);
        assert_eq!(w.period_elapsed(), None);
    }
    // A frame counts only for the period it arrived in.
    w.frame_received();
    assert_eq!(w.period_elapsed(), None);
    assert_eq!(w.period_elapsed(), None);
    assert_eq!(w.period_elapsed(), None);
    assert!(w.period_elapsed().is_some());
}

#[test]
fn safe_is_latched_until_arm() {
    let mut w = Watchdog::new(2);
    w.arm();
    w.period_elapsed();
    let f = w.period_elapsed().unwrap();
    for _ in 0..10 {
        w.frame_received();
        assert_eq!(w.period_elapsed(), None);
        assert_eq!(w.state(), BoardState::Safe(f));
        assert_eq!(w.output(REQ), SAFE_CODES);
    }
    w.arm();
    assert_eq!(w.state(), BoardState::Armed);
    assert_eq!(w.missed(), 0);
    assert_eq!(w.output(REQ), REQ);
    // Disarm from Safe also leaves it, to Disarmed.
    w.fault(Fault { reason: FaultReason::Operator, detail: 0 });
    w.disarm();
    assert_eq!(w.state(), BoardState::Disarmed);
    assert_eq!(w.output(REQ), SAFE_CODES);
}

#[test]
fn first_fault_reason_is_kept() {
    let mut w = Watchdog::new(3);
    w.arm();
    let first = Fault { reason: FaultReason::Overrun, detail: 7 };
    w.fault(first);
    w.fault(Fault { reason: FaultReason::Operator, detail: 1 });
    for _ in 0..5 {
        assert_eq!(w.period_elapsed(), None);
    }
    assert_eq!(w.state(), BoardState::Safe(first));
    // A fault while disarmed also latches.
    let mut w = Watchdog::new(3);
    w.fault(Fault { reason: FaultReason::LinkDead, detail: 0 });
    assert_eq!(w.state(), BoardState::Safe(Fault { reason: FaultReason::LinkDead, detail: 0 }));
    assert_eq!(w.output(REQ), SAFE_CODES);
}

#[test]
fn lockstep_wall_clock_silence_is_not_a_missed_period() {
    // The controller is merely slow: 100 silent wall-clock periods, far past the limit of
    // 3, and the watchdog stays armed; the next frame clears the silence.
    let mut w = Watchdog::lockstep(3, 250);
    assert!(w.is_lockstep() && !Watchdog::new(3).is_lockstep());
    w.arm();
    w.frame_received();
    for _ in 0..100 {
        assert_eq!(w.period_elapsed(), None);
    }
    assert_eq!((w.state(), w.missed(), w.silent()), (BoardState::Armed, 0, 99));
    assert_eq!(w.frames_lost(0), None);
    w.frame_received();
    assert_eq!((w.missed(), w.silent()), (0, 0));
    assert_eq!(w.output(REQ), REQ);
}

#[test]
fn lockstep_trips_on_n_lost_transmissions_in_a_row() {
    for n in 1..=5u32 {
        let mut w = Watchdog::lockstep(n, 250);
        w.arm();
        // Gaps below the limit are isolated losses, repaired by the controller's repeat.
        for missing in 0..n {
            assert_eq!(w.frames_lost(missing), None, "limit {n}, gap {missing}");
            w.frame_received();
            assert_eq!(w.state(), BoardState::Armed);
        }
        let f = Fault { reason: FaultReason::Silence, detail: n + 1 };
        assert_eq!(w.frames_lost(n + 1), Some(f), "limit {n}");
        assert_eq!((w.state(), w.missed()), (BoardState::Safe(f), n + 1));
        // The frame after the gap does not unlatch it, and the trip is reported once.
        w.frame_received();
        assert_eq!(w.frames_lost(n), None);
        assert_eq!(w.state(), BoardState::Safe(f));
        assert_eq!(w.output(REQ), SAFE_CODES);
    }
    let mut w = Watchdog::lockstep(3, 250);
    w.arm();
    assert_eq!(w.frames_lost(3), Some(Fault { reason: FaultReason::Silence, detail: 3 }));
}

#[test]
fn lockstep_latches_link_dead_after_the_dead_link_bound() {
    let mut w = Watchdog::lockstep(3, 5);
    assert_eq!(w.dead_link_limit(), 5);
    w.arm();
    for _ in 0..4 {
        assert_eq!(w.period_elapsed(), None);
    }
    let f = Fault { reason: FaultReason::LinkDead, detail: 5 };
    assert_eq!(w.period_elapsed(), Some(f));
    assert_eq!(w.state(), BoardState::Safe(f));
    assert_eq!(w.period_elapsed(), None, "reported once");
    // A frame in the period resets the bound.
    let mut w = Watchdog::lockstep(3, 5);
    w.arm();
    for _ in 0..20 {
        for _ in 0..4 {
            assert_eq!(w.period_elapsed(), None);
        }
        w.frame_received();
        assert_eq!(w.period_elapsed(), None);
    }
    assert_eq!(w.state(), BoardState::Armed);
    // Limits of 0 are clamped to 1, and nothing counts while disarmed.
    let mut w = Watchdog::lockstep(0, 0);
    assert_eq!((w.limit(), w.dead_link_limit()), (1, 1));
    assert_eq!(w.period_elapsed(), None);
    assert_eq!(w.frames_lost(9), None);
    w.arm();
    assert!(w.period_elapsed().is_some());
}

#[test]
fn real_time_ignores_sequence_gaps() {
    // The wall clock already counted the periods the lost frames belonged to.
    let mut w = Watchdog::new(3);
    w.arm();
    assert_eq!(w.frames_lost(10), None);
    w.frame_received();
    assert_eq!(w.state(), BoardState::Armed);
    assert_eq!((w.silent(), w.dead_link_limit()), (0, 0));
}
