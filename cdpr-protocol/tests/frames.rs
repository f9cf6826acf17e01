//! Frames: golden bytes computed outside Rust (Python's `zlib.crc32` and a
//! COBS written from the algorithm's definition), round trips, and hostile
//! byte streams (bit flips, truncation, garbage, oversize) that must be
//! rejected without a panic.

use cdpr_protocol::{
    crc32, decode, decode_payload_serde, encode, Counters, DeviceMessage, DriveFault, DriveFaultCause,
    FrameDecoder, FrameError, HostMessage, Identity, Message, Reason, Rejection, Setpoint, State, Telemetry,
    TrajectoryPoint, CABLES, IDENTITY_NAME_LEN, MAX_FRAME, MAX_PAYLOAD,
};
use proptest::prelude::*;

fn frame_of<T: serde::Serialize>(message: &T) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let n = encode(message, &mut out).expect("encodes");
    out[..n].to_vec()
}

/// Feeds a byte stream and collects every frame's outcome.
fn feed<T: Message>(bytes: &[u8]) -> Vec<Result<T, FrameError>> {
    let mut decoder = FrameDecoder::new();
    bytes.iter().filter_map(|&b| decoder.push::<T>(b)).collect()
}

#[test]
fn crc_check_value() {
    // The catalogue check value of CRC-32/ISO-HDLC.
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
}

#[test]
fn golden_enable_frame() {
    // postcard(Enable) = [0x01]; zlib.crc32(b"\x01") = 0xA505DF1B.
    assert_eq!(frame_of(&HostMessage::Enable), [0x06, 0x01, 0x1b, 0xdf, 0x05, 0xa5, 0x00]);
}

#[test]
fn golden_setpoint_frame() {
    // Tag 0, seq 1 (varint), six 0.5 (0x3f000000 LE), twelve 0.0: many zero
    // bytes for COBS to stuff. Bytes from a Python reference.
    let setpoint = Setpoint { seq: 1, pose: [0.5; 6], velocity: [0.0; 6], acceleration: [0.0; 6] };
    let mut expected = vec![0x01, 0x02, 0x01];
    for _ in 0..6 {
        expected.extend([0x01, 0x01, 0x02, 0x3f]);
    }
    expected.extend([0x01; 47]);
    expected.extend([0x05, 0x4a, 0xc8, 0xaf, 0xc6, 0x00]);
    assert_eq!(expected.len(), 80);
    assert_eq!(frame_of(&HostMessage::Setpoint(setpoint)), expected);
}

#[test]
fn largest_message_fits() {
    let telemetry = Telemetry {
        cycle: u32::MAX,
        setpoint_seq: u32::MAX,
        state: State::Fault,
        reason: Reason::HoldTimeout,
        hold_reason: Reason::Infeasible,
        solved: true,
        tensions: [f32::MAX; CABLES],
        torques: [-f32::MAX; CABLES],
        brakes: true,
        step_cost: u32::MAX,
        counters: Counters {
            accepted: u32::MAX,
            rejected_framing: u32::MAX,
            rejected_crc: u32::MAX,
            rejected_decode: u32::MAX,
            rejected_order: u32::MAX,
            rejected_range: u32::MAX,
            rejected_state: u32::MAX,
            overruns: u32::MAX,
            infeasible: u32::MAX,
            faults: u32::MAX,
            rejected_jump: u32::MAX,
            rejected_method: u32::MAX,
            dropped_bytes: u32::MAX,
            last_rejection: Rejection::Homing,
        },
        method: u8::MAX,
        estimate: [f32::MAX; 6],
        residual: f32::NAN,
        homed: true,
        feedback: u8::MAX,
        unreadable_drive: Some(u8::MAX),
        tension_limited: u8::MAX,
        feedback_scale: u8::MAX,
        buffer_fill: u8::MAX,
        buffer_lead_ms: u16::MAX,
        drive_fault: Some(DriveFault {
            drive: u8::MAX,
            cause: DriveFaultCause::Configuration,
            code: u32::MAX,
        }),
    };
    let frame = frame_of(&DeviceMessage::Telemetry(telemetry));
    assert!(frame.len() <= MAX_FRAME, "{} bytes", frame.len());
    // The payload's size at most (stated in the protocol's docs): the
    // frame less the COBS code byte, the CRC and the delimiter.
    let mut buf = [0u8; MAX_PAYLOAD];
    let payload = postcard::to_slice(&DeviceMessage::Telemetry(telemetry), &mut buf).unwrap();
    assert_eq!(payload.len(), 198);
    assert!(payload.len() <= MAX_PAYLOAD);
    let decoded = feed::<DeviceMessage>(&frame);
    let Some(Ok(DeviceMessage::Telemetry(back))) = decoded.first().cloned() else { panic!("{decoded:?}") };
    assert!(back.residual.is_nan());
    assert_eq!(back.unreadable_drive, Some(u8::MAX));
    assert_eq!(back.drive_fault, telemetry.drive_fault);
    let telemetry = Telemetry { residual: 0.0, unreadable_drive: None, drive_fault: None, ..telemetry };
    let frame = frame_of(&DeviceMessage::Telemetry(telemetry));
    assert_eq!(feed::<DeviceMessage>(&frame), vec![Ok(DeviceMessage::Telemetry(telemetry))]);
}

/// Raw payload bytes with a correct CRC, COBS-framed by the test itself.
#[test]
fn a_trajectory_point_frame_is_at_most_60_bytes() {
    // The link budget (firmware README) counts 60 bytes per point: tag 9,
    // the time as a varint (5 bytes at most), 12 floats, CRC, COBS, 0x00.
    let point = TrajectoryPoint { time_ms: u32::MAX, pose: [f32::MAX; 6], velocity: [f32::MIN; 6] };
    let frame = frame_of(&HostMessage::Point(point));
    assert_eq!(frame.len(), 60);
    let decoded = feed::<HostMessage>(&frame);
    assert_eq!(decoded, vec![Ok(HostMessage::Point(point))]);
    // The tag is the enum's tenth: 9.
    let mut buf = [0u8; MAX_PAYLOAD];
    let payload = postcard::to_slice(&HostMessage::Point(point), &mut buf).unwrap();
    assert_eq!(payload[0], 9);
}

fn framed_raw(payload: &[u8]) -> Vec<u8> {
    let mut raw = payload.to_vec();
    raw.extend(crc32(payload).to_le_bytes());
    let mut out = vec![0u8; MAX_FRAME + 8];
    let n = cobs::try_encode(&raw, &mut out).unwrap();
    out.truncate(n);
    out.push(0);
    out
}

/// `Identify` is tag 8 (appended: the tags before it did not move); the
/// answer is `DeviceMessage` tag 1: 24 name bytes, the length, the hash as
/// a varint, the shape.
#[test]
fn identify_and_identity() {
    assert_eq!(payload_of(&HostMessage::Identify), [0x08]);
    assert_eq!(feed::<HostMessage>(&frame_of(&HostMessage::Identify)), vec![Ok(HostMessage::Identify)]);
    let id = Identity::new("suspended-8", 0x0123_4567_89ab_cdef, 6, 8);
    assert_eq!(id.name(), Some("suspended-8"));
    assert_eq!(id.name_len, 11);
    let message = DeviceMessage::Identity(id);
    let mut buf = [0u8; MAX_PAYLOAD];
    let payload = postcard::to_slice(&message, &mut buf).unwrap().to_vec();
    assert_eq!(payload[0], 1);
    assert_eq!(&payload[1..12], b"suspended-8");
    assert!(payload[12..25].iter().all(|&b| b == 0));
    assert_eq!(payload[25], 11);
    assert_eq!(payload[payload.len() - 2..], [6, 8]);
    assert_eq!(feed::<DeviceMessage>(&frame_of(&message)), vec![Ok(message)]);
    // The largest identity fits a frame.
    let widest = DeviceMessage::Identity(Identity::new(&"x".repeat(40), u64::MAX, u8::MAX, u8::MAX));
    assert!(frame_of(&widest).len() <= MAX_FRAME);
    // Long names are cut to 24 bytes, at a character boundary.
    assert_eq!(Identity::new(&"ab".repeat(20), 0, 6, 8).name(), Some("abababababababababababab"));
    let accents = "é".repeat(20); // two bytes each: 12 fit
    let cut = Identity::new(&accents, 0, 6, 8);
    assert_eq!(cut.name(), Some("é".repeat(12).as_str()));
    let odd = format!("a{accents}"); // 1 + 2k bytes: 23 fit
    assert_eq!(Identity::new(&odd, 0, 6, 8).name().map(str::len), Some(23));
    assert_eq!(Identity::new("", 7, 6, 8).name(), Some(""));
}

/// Hostile identities decode without a panic; a malformed one has no name.
#[test]
fn hostile_identities() {
    let good = DeviceMessage::Identity(Identity::new("ipanema1", 42, 6, 8));
    let mut buf = [0u8; MAX_PAYLOAD];
    let payload = postcard::to_slice(&good, &mut buf).unwrap().to_vec();
    // name_len beyond the array.
    let mut long = payload.clone();
    long[1 + IDENTITY_NAME_LEN] = 200;
    let Ok(DeviceMessage::Identity(id)) = feed::<DeviceMessage>(&framed_raw(&long))[0] else { panic!() };
    assert_eq!(id.name(), None);
    // Bytes that are not UTF-8.
    let mut bad = payload.clone();
    bad[1] = 0xff;
    let Ok(DeviceMessage::Identity(id)) = feed::<DeviceMessage>(&framed_raw(&bad))[0] else { panic!() };
    assert_eq!(id.name(), None);
    // Every truncation is rejected; an overlong hash varint too.
    for cut in 1..payload.len() {
        assert!(feed::<DeviceMessage>(&framed_raw(&payload[..cut])).iter().all(|r| r.is_err()), "cut {cut}");
    }
    let mut overlong = payload[..1 + IDENTITY_NAME_LEN + 1].to_vec();
    overlong.extend([0xaa, 0x80, 0x00, 6, 8]); // 42 as three bytes
    assert_eq!(feed::<DeviceMessage>(&framed_raw(&overlong)), vec![Err(FrameError::Decode)]);
    // An unknown device tag.
    assert_eq!(feed::<DeviceMessage>(&framed_raw(&[2])), vec![Err(FrameError::Decode)]);
}

#[test]
fn good_crc_but_not_a_message() {
    // Tag 9 names no HostMessage variant.
    assert_eq!(feed::<HostMessage>(&framed_raw(&[9])), vec![Err(FrameError::Decode)]);
    // A setpoint cut short: the CRC is right, the fields are missing.
    assert_eq!(feed::<HostMessage>(&framed_raw(&[0, 1, 0, 0])), vec![Err(FrameError::Decode)]);
    // Enable followed by a stray byte.
    assert_eq!(feed::<HostMessage>(&framed_raw(&[1, 7])), vec![Err(FrameError::TrailingBytes)]);
}

#[test]
fn short_and_empty_frames() {
    // Two delimiters in a row: an empty frame, skipped.
    assert!(feed::<HostMessage>(&[0, 0, 0]).is_empty());
    // COBS of fewer than five bytes cannot hold a payload and a CRC.
    assert_eq!(feed::<HostMessage>(&[0x03, 0x01, 0x02, 0x00]), vec![Err(FrameError::Crc)]);
    // A COBS code pointing past the end of the frame.
    assert_eq!(feed::<HostMessage>(&[0x09, 0x01, 0x00]), vec![Err(FrameError::Framing)]);
}

#[test]
fn oversize_is_dropped_and_the_next_frame_decodes() {
    let mut stream = vec![0x55u8; MAX_FRAME + 10];
    stream.push(0);
    stream.extend(frame_of(&HostMessage::Disable));
    assert_eq!(feed::<HostMessage>(&stream), vec![Err(FrameError::Oversize), Ok(HostMessage::Disable)]);
}

#[test]
fn encode_into_a_small_buffer_fails_cleanly() {
    let mut out = [0u8; 6];
    assert_eq!(encode(&HostMessage::Enable, &mut out), Err(FrameError::BufferTooSmall));
    let mut out = [0u8; 7];
    assert_eq!(encode(&HostMessage::Enable, &mut out), Ok(7));
}

#[test]
fn decode_of_an_empty_slice() {
    assert_eq!(decode::<HostMessage>(&mut []), Err(FrameError::Framing));
}

fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![any::<f32>(), Just(f32::NAN), Just(f32::INFINITY), Just(0.0f32), -10.0f32..10.0]
}

fn any_setpoint() -> impl Strategy<Value = Setpoint> {
    (
        any::<u32>(),
        prop::array::uniform6(any_f32()),
        prop::array::uniform6(any_f32()),
        prop::array::uniform6(any_f32()),
    )
        .prop_map(|(seq, pose, velocity, acceleration)| Setpoint { seq, pose, velocity, acceleration })
}

fn any_host_message() -> impl Strategy<Value = HostMessage> {
    prop_oneof![
        any_setpoint().prop_map(HostMessage::Setpoint),
        Just(HostMessage::Enable),
        Just(HostMessage::Disable),
        Just(HostMessage::ClearFault),
        any::<u16>().prop_map(HostMessage::TelemetryPeriod),
        any::<u8>().prop_map(HostMessage::SelectMethod),
        prop::array::uniform6(any_f32()).prop_map(HostMessage::Home),
        any::<u8>().prop_map(HostMessage::SelectFeedback),
        Just(HostMessage::Identify),
        (any::<u32>(), prop::array::uniform6(any_f32()), prop::array::uniform6(any_f32())).prop_map(
            |(time_ms, pose, velocity)| HostMessage::Point(TrajectoryPoint { time_ms, pose, velocity })
        ),
    ]
}

/// Equality that treats NaN payloads bit for bit.
fn same_bits(a: &HostMessage, b: &HostMessage) -> bool {
    match (a, b) {
        (HostMessage::Setpoint(x), HostMessage::Setpoint(y)) => {
            let bits = |s: &Setpoint| {
                (
                    s.seq,
                    s.pose.map(f32::to_bits),
                    s.velocity.map(f32::to_bits),
                    s.acceleration.map(f32::to_bits),
                )
            };
            bits(x) == bits(y)
        }
        (HostMessage::Home(x), HostMessage::Home(y)) => x.map(f32::to_bits) == y.map(f32::to_bits),
        (HostMessage::Point(x), HostMessage::Point(y)) => {
            let bits =
                |p: &TrajectoryPoint| (p.time_ms, p.pose.map(f32::to_bits), p.velocity.map(f32::to_bits));
            bits(x) == bits(y)
        }
        _ => a == b,
    }
}

/// `cases` cases, failures saved beside this file
/// (`frames.proptest-regressions`) and committed, replayed first.
fn persisted(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource(
            "proptest-regressions",
        ))),
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(persisted(1000))]

    /// Any message survives encoding and decoding, also in a stream that
    /// starts with garbage (the decoder resynchronises at a delimiter).
    #[test]
    fn round_trip(messages in prop::collection::vec(any_host_message(), 1..6),
                  junk in prop::collection::vec(1u8..=255, 0..40)) {
        let mut stream = junk.clone();
        stream.push(0);
        for m in &messages {
            stream.extend(frame_of(m));
        }
        let out = feed::<HostMessage>(&stream);
        let decoded: Vec<HostMessage> = out.iter().filter_map(|r| r.as_ref().ok().copied()).collect();
        prop_assert_eq!(decoded.len(), messages.len());
        for (a, b) in decoded.iter().zip(&messages) {
            prop_assert!(same_bits(a, b), "{:?} != {:?}", a, b);
        }
    }

    /// Flipping any one bit of a frame never yields a message: CRC-32
    /// detects every single-bit error, and a flip that makes or removes a
    /// delimiter breaks the framing.
    #[test]
    fn single_bit_flips_are_rejected(message in any_host_message(), pick in any::<prop::sample::Index>(), bit in 0u8..8) {
        let mut frame = frame_of(&message);
        let i = pick.index(frame.len());
        frame[i] ^= 1 << bit;
        frame.push(0); // end whatever frame the flip left open
        let out = feed::<HostMessage>(&frame);
        prop_assert!(out.iter().all(|r| r.is_err()), "{:?} from a corrupted frame", out);
        prop_assert!(!out.is_empty());
    }

    /// Any truncated frame, closed by a delimiter, is rejected.
    #[test]
    fn truncated_frames_are_rejected(message in any_host_message(), pick in any::<prop::sample::Index>()) {
        let frame = frame_of(&message);
        let cut = 1 + pick.index(frame.len() - 2); // keep at least one byte, drop at least the delimiter and one more
        let mut stream = frame[..cut].to_vec();
        stream.push(0);
        let out = feed::<HostMessage>(&stream);
        prop_assert_eq!(out.len(), 1);
        prop_assert!(out[0].is_err());
    }

    /// Arbitrary bytes never panic the decoder, and a frame after them
    /// still decodes.
    #[test]
    fn garbage_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        let mut stream = bytes;
        stream.push(0);
        stream.extend(frame_of(&HostMessage::ClearFault));
        let out = feed::<HostMessage>(&stream);
        prop_assert_eq!(out.last(), Some(&Ok(HostMessage::ClearFault)));
    }
}

/// The postcard payload of `message` (no CRC, no COBS).
fn payload_of(message: &HostMessage) -> Vec<u8> {
    let mut out = [0u8; 200];
    postcard::to_slice(message, &mut out).unwrap().to_vec()
}

#[test]
fn overlong_varints_are_rejected() {
    // The frame: Enable with the tag `81 00` (a correct CRC).
    let overlong_enable = [0x02, 0x81, 0x05, 0xf5, 0xbb, 0x41, 0x63, 0x00];
    assert_eq!(framed_raw(&[0x81, 0x00]), overlong_enable);
    assert_eq!(feed::<HostMessage>(&overlong_enable), vec![Err(FrameError::Decode)]);
    // A setpoint whose seq 1 takes five bytes.
    let canonical = payload_of(&HostMessage::Setpoint(Setpoint {
        seq: 1,
        pose: [0.5; 6],
        velocity: [0.0; 6],
        acceleration: [0.0; 6],
    }));
    let mut overlong = vec![0x00, 0x81, 0x80, 0x80, 0x80, 0x00];
    overlong.extend(&canonical[2..]);
    assert_eq!(feed::<HostMessage>(&framed_raw(&overlong)), vec![Err(FrameError::Decode)]);
    assert!(matches!(feed::<HostMessage>(&framed_raw(&canonical))[..], [Ok(_)]));
    // TelemetryPeriod(5) with a two-byte 5.
    assert_eq!(feed::<HostMessage>(&framed_raw(&[0x04, 0x85, 0x00])), vec![Err(FrameError::Decode)]);
    assert_eq!(feed::<HostMessage>(&framed_raw(&[0x04, 0x05])), vec![Ok(HostMessage::TelemetryPeriod(5))]);
}

/// One edit of a payload: overwrite a byte, insert one, remove one, or make
/// a varint-looking byte overlong (`b` -> `b | 0x80, 0x00`).
#[derive(Debug, Clone)]
enum Edit {
    Set(prop::sample::Index, u8),
    Insert(prop::sample::Index, u8),
    Remove(prop::sample::Index),
    Overlong(prop::sample::Index),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        1 => (any::<prop::sample::Index>(), any::<u8>()).prop_map(|(i, b)| Edit::Set(i, b)),
        1 => (any::<prop::sample::Index>(), any::<u8>()).prop_map(|(i, b)| Edit::Insert(i, b)),
        1 => any::<prop::sample::Index>().prop_map(Edit::Remove),
        3 => any::<prop::sample::Index>().prop_map(Edit::Overlong),
    ]
}

proptest! {
    #![proptest_config(persisted(3000))]

    /// A fuzz of the decoder: payloads of valid messages with random edits,
    /// CRC and COBS made right so that only the decoder judges them. Every
    /// accepted payload is the canonical encoding of its message (it
    /// re-encodes to the same bytes), so each message has one encoding.
    #[test]
    fn only_canonical_encodings_are_accepted(message in any_host_message(), edits in prop::collection::vec(edit(), 1..4)) {
        let mut payload = payload_of(&message);
        for e in edits {
            match e {
                Edit::Set(i, b) => { let i = i.index(payload.len()); payload[i] = b }
                Edit::Insert(i, b) => { let i = i.index(payload.len() + 1); payload.insert(i, b) }
                Edit::Remove(i) => { if payload.len() > 1 { let i = i.index(payload.len()); payload.remove(i); } }
                Edit::Overlong(i) => {
                    let i = i.index(payload.len());
                    if payload[i] < 0x80 { payload[i] |= 0x80; payload.insert(i + 1, 0x00) }
                }
            }
        }
        for decoded in feed::<HostMessage>(&framed_raw(&payload)).into_iter().flatten() {
            prop_assert_eq!(payload_of(&decoded), payload.clone(), "{:?}", decoded);
        }
    }
}

/// The reference receiver: the stream cut at every delimiter, each
/// non-empty piece longer than `MAX_FRAME` rejected as oversize and the
/// others decoded whole by [`decode`] (the `cobs` crate's COBS, serde's
/// postcard with the re-encoding check).
fn reference_feed(bytes: &[u8]) -> Vec<Result<HostMessage, FrameError>> {
    let mut out = Vec::new();
    let mut piece = Vec::new();
    for &b in bytes {
        if b != 0 {
            piece.push(b);
            continue;
        }
        if piece.len() > MAX_FRAME {
            out.push(Err(FrameError::Oversize));
        } else if !piece.is_empty() {
            out.push(decode::<HostMessage>(&mut piece));
        }
        piece.clear();
    }
    out
}

fn same_outcomes(a: &[Result<HostMessage, FrameError>], b: &[Result<HostMessage, FrameError>]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(x, y)| match (x, y) {
            (Ok(x), Ok(y)) => same_bits(x, y),
            _ => x == y,
        })
}

/// A stream piece for the receivers' comparison: a valid frame, a frame
/// with a byte changed (COBS, CRC or payload), a payload with a setpoint's
/// or a point's tag and arbitrary bytes after it (CRC and COBS right, so
/// the message decoder judges it), or raw bytes.
fn stream_piece() -> impl Strategy<Value = Vec<u8>> {
    let tagged = (prop_oneof![Just(0u8), Just(9u8), any::<u8>()], prop::collection::vec(any::<u8>(), 0..90))
        .prop_map(|(tag, mut rest)| {
            rest.insert(0, tag);
            framed_raw(&rest)
        });
    prop_oneof![
        2 => any_host_message().prop_map(|m| frame_of(&m)),
        2 => (any_host_message(), any::<prop::sample::Index>(), any::<u8>()).prop_map(|(m, i, b)| {
            let mut f = frame_of(&m);
            let i = i.index(f.len());
            f[i] = b;
            f
        }),
        3 => tagged,
        1 => prop::collection::vec(any::<u8>(), 0..300),
        1 => prop::collection::vec(1u8..=255, 200..260),
    ]
}

proptest! {
    #![proptest_config(persisted(3000))]

    /// The firmware's receiver (COBS undone as the bytes arrive, setpoints
    /// and points decoded without serde) gives frame for frame what the
    /// reference receiver gives: the same message bit for bit, or the same
    /// error. Counts how many frames of each outcome it compared.
    #[test]
    fn the_receiver_agrees_with_the_reference(pieces in prop::collection::vec(stream_piece(), 1..6)) {
        let stream: Vec<u8> = pieces.concat();
        let ours = feed::<HostMessage>(&stream);
        let reference = reference_feed(&stream);
        prop_assert!(same_outcomes(&ours, &reference), "ours {:?}\nreference {:?}", ours, reference);
    }

    /// The direct decoding of tags 0 and 9 against serde's on arbitrary
    /// payloads with those tags: same message or same error.
    #[test]
    fn direct_decoding_agrees_with_serde(tag in prop_oneof![Just(0u8), Just(9u8)], rest in prop::collection::vec(any::<u8>(), 0..90)) {
        let mut payload = vec![tag];
        payload.extend(rest);
        let ours = HostMessage::from_payload(&payload);
        let reference = decode_payload_serde::<HostMessage>(&payload);
        prop_assert!(same_outcomes(&[ours], &[reference]), "{:?}", payload);
    }
}

/// The comparison above reaches every outcome: over a fixed sample of
/// pieces, each of accepted setpoints and points, framing, CRC, decode,
/// trailing-bytes and oversize rejections occurs, and the receivers agree
/// on all of them.
#[test]
fn the_receiver_comparison_reaches_every_outcome() {
    use proptest::strategy::ValueTree;
    let mut runner = proptest::test_runner::TestRunner::deterministic();
    let mut seen = std::collections::BTreeMap::<&str, usize>::new();
    for _ in 0..20_000 {
        let stream = stream_piece().new_tree(&mut runner).unwrap().current();
        let ours = feed::<HostMessage>(&stream);
        assert!(same_outcomes(&ours, &reference_feed(&stream)), "{stream:?}");
        for o in &ours {
            let kind = match o {
                Ok(HostMessage::Setpoint(_)) => "setpoint",
                Ok(HostMessage::Point(_)) => "point",
                Ok(_) => "other message",
                Err(FrameError::Framing) => "framing",
                Err(FrameError::Crc) => "crc",
                Err(FrameError::Decode) => "decode",
                Err(FrameError::TrailingBytes) => "trailing bytes",
                Err(FrameError::Oversize) => "oversize",
                Err(FrameError::BufferTooSmall) => "buffer too small",
            };
            *seen.entry(kind).or_default() += 1;
        }
    }
    for kind in
        ["setpoint", "point", "other message", "framing", "crc", "decode", "trailing bytes", "oversize"]
    {
        assert!(seen.get(kind).copied().unwrap_or(0) >= 20, "{kind}: {seen:?}");
    }
}

proptest! {
    #![proptest_config(persisted(2000))]

    /// The batched receive loop (`take_bytes` with limits cutting the
    /// stream anywhere, then `finish` at each frame's end) gives the same
    /// frames as `push` byte by byte.
    #[test]
    fn batched_taking_agrees_with_byte_by_byte(
        pieces in prop::collection::vec(stream_piece(), 1..6),
        limits in prop::collection::vec(1usize..300, 1..40),
    ) {
        let stream: Vec<u8> = pieces.concat();
        let mut decoder = FrameDecoder::new();
        let mut bytes = stream.iter().copied();
        let mut next = || bytes.next();
        let mut out = Vec::new();
        let mut total = 0;
        for &limit in limits.iter().cycle().take(10_000) {
            let (n, ended) = decoder.take_bytes(&mut next, limit);
            prop_assert!(n <= limit);
            total += n;
            if ended {
                out.extend(decoder.finish::<HostMessage>());
            } else if n < limit {
                break;
            }
        }
        prop_assert_eq!(total, stream.len());
        prop_assert!(same_outcomes(&out, &feed::<HostMessage>(&stream)));
    }

    /// The board's split (the receive interrupt reassembles `LineFrame`s,
    /// the control step checks and decodes them) gives the same frames as
    /// `push` byte by byte.
    #[test]
    fn line_frames_agree_with_byte_by_byte(pieces in prop::collection::vec(stream_piece(), 1..6)) {
        let stream: Vec<u8> = pieces.concat();
        let mut decoder = cdpr_protocol::FrameDecoder::new();
        let mut out = Vec::new();
        for &b in &stream {
            if decoder.push_byte(b) {
                out.extend(decoder.finish_line().map(|f| f.message::<HostMessage>()));
            }
        }
        prop_assert!(same_outcomes(&out, &feed::<HostMessage>(&stream)));
    }
}

proptest! {
    #![proptest_config(persisted(3000))]

    /// The slicing-by-4 CRC-32 against the `crc` crate's CRC-32/ISO-HDLC,
    /// every length from 0 to 300 bytes (all four remainders).
    #[test]
    fn crc32_agrees_with_the_crc_crate(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        let reference = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&bytes);
        prop_assert_eq!(crc32(&bytes), reference);
    }
}
