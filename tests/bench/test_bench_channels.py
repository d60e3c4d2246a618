"""Several channels end to end: an emulated device of N channels against N one-channel devices
(closed loop, sample for sample), `--channel` and `--channels` and their bad values in one line,
`list` with the channel count, protocol 3 refusing protocol 2 both ways, CAN telemetry of several
channels, and the telemetry budget PROTOCOL.md states against the frames' sizes."""

import csv
import re

import pytest

from cosim.bench.__main__ import main as bench_cli
from cosim.bench.emulate.emulator import Emulator
from cosim.bench.emulate.host_device import Device
from cosim.bench.link import messages as msgs
from cosim.bench.link import protocol as proto
from cosim.bench.link.api import Bench
from cosim.bench.link.recorder import channel_path, progress_line, record_run
from cosim.project.paths import REPO_ROOT

# Each channel's own settings: different gains and compensators, so that a write to the wrong
# bank or a shared state shows.
SETTINGS = [
    {"loop.kp": 0.1, "comp.mode": "paper"},
    {"loop.kp": 0.3, "comp.mode": "smooth"},
    {"loop.kp": 0.2, "comp.mode": "none"},
]
RUN = {"seconds": 0.3, "waveform": "sine", "mean_n": 8.5, "amplitude_n": 6.5, "freq_hz": 2.0}


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.reader(f))


def test_each_channel_of_an_emulated_device_is_a_one_channel_device(tmp_path):
    """Three channels in one tick (each its loop model and plant) record what three
    one-channel devices with the same settings record, row for row."""
    with Bench(emulate=True, channels=3) as bench:
        c = bench.client
        assert bench.connect_info.n_channels == 3
        for k, settings in enumerate(SETTINGS):
            for name, value in settings.items():
                c.set(name, value, channel=k)
        record_run(c, tmp_path / "all.csv", channels=(0, 1, 2), **RUN)
    many = [_rows(channel_path(tmp_path / "all.csv", k, (0, 1, 2))) for k in range(3)]
    for k, settings in enumerate(SETTINGS):
        with Bench(emulate=True) as bench:
            for name, value in settings.items():
                bench.client.set(name, value)
            record_run(bench.client, tmp_path / f"one{k}.csv", **RUN)
        one = _rows(tmp_path / f"one{k}.csv")
        assert len(one) == len(many[k]) == 301  # header + 0.3 s at 1 kHz
        assert many[k] == one, f"channel {k} differs from its one-channel device"
    assert many[0][1:] != many[1][1:]  # the channels did differ from each other


def test_a_divided_telemetry_of_several_channels_is_recorded_whole(tmp_path):
    """dev.telemetry_div 2 on three channels: the device sends channel k's samples with sample %
    2 == k % 2 (its frames spread over the ticks), and the recorder expects exactly those: every
    one recorded, no gap, the run complete (301 ticks: 151 samples of channels 0 and 2, 150 of
    channel 1), each at its tick's time (t_s the sample over the 1 kHz tick rate, not over the
    rows' 500 Hz, which stretched the record's time twice)."""
    lines = []
    with Bench(emulate=True, channels=3) as bench:
        c = bench.client
        c.set("dev.telemetry_div", 2)
        run = record_run(
            c, tmp_path / "div.csv", channels=(0, 1, 2), progress=lines.append,
            **{**RUN, "seconds": 0.301},
        )  # fmt: skip
    assert (run.samples, run.expected, run.drops, run.gaps) == (452, 452, 0, []), run.summary()
    # The progress line counts the run's time (the ticks every channel reached), not the samples
    # of the three channels together, which read 0.9 s of this 0.3 s run.
    assert lines and all(float(line.split("/")[0]) <= 0.302 for line in lines if line), lines
    assert progress_line(run, 301, 1000.0, 0.301, 1.0).startswith("   0.3/0.301 s     301 Hz")
    for k in range(3):
        rows = _rows(channel_path(tmp_path / "div.csv", k, (0, 1, 2)))
        samples = [int(r[rows[0].index("sample")]) for r in rows[1:]]
        assert samples == list(range(k % 2, 301, 2)), (k, samples[:4])
        t_s = [float(r[rows[0].index("t_s")]) for r in rows[1:]]
        assert t_s == pytest.approx([n / 1000.0 for n in samples], abs=1e-9), (k, t_s[:4])


@pytest.mark.parametrize(
    ("argv", "text"),
    [
        (["--channel", "x", "info"], "expected a channel number (0, 1, ...) or all; got 'x'"),
        (["--channel", "-1", "info"], "got '-1'"),
        (["--channel", "1.5", "info"], "got '1.5'"),
        (["--channel", "1", "info"], "--channel 1: the device has 1 channel (channel 0)"),
        (["--channels", "2", "--channel", "2", "info"], "has 2 channels (channels 0..1)"),
        (["--channels", "0", "info"], "--channels: expected a whole number 1..4; got '0'"),
        (["--channels", "two", "info"], "got 'two'"),
        (["--channel", "all", "backup", "b.json"], "backup takes one channel (--channel K)"),
    ],
)
def test_bad_channels_are_one_line_and_exit_2(argv, text, capsys, tmp_path, monkeypatch):
    from cosim.cli import main  # noqa: PLC0415 (`bowden`: its parser's errors are one line)

    monkeypatch.chdir(tmp_path)
    rc = main(["bench", "--emulate", *argv])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and text in err, (argv, err)
    assert not (tmp_path / "b.json").exists()


def test_channels_needs_the_emulator(capsys):
    rc = bench_cli(["bench", "--port", "socket://localhost:1", "--channels", "2", "info"])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "needs --emulate" in err


def test_get_set_and_faults_of_all_channels(capsys):
    argv = ["bench", "--emulate", "--channels", "2", "--channel"]
    assert bench_cli([*argv, "all", "set", "loop.kp=0.25"]) == 0
    out = capsys.readouterr().out
    assert "[ch 0] loop.kp = 0.25 A/N" in out and "[ch 1] loop.kp = 0.25 A/N" in out
    assert bench_cli([*argv, "all", "get", "comp.mode", "dev.telemetry_div"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["ch", "0", "ch", "1"]
    assert lines[1].split() == ["comp.mode", "paper", "paper"]
    assert bench_cli([*argv, "1", "faults"]) == 0
    assert "FPGA faults    none" in capsys.readouterr().out
    assert bench_cli([*argv, "all", "info"]) == 0
    out = capsys.readouterr().out
    assert "channels      2" in out and "channel 1: FPGA none" in out


def test_list_shows_the_channel_count(capsys):
    emu = Emulator(tcp_port=0, pty=False, channels=3).start()
    try:
        assert bench_cli(["bench", "--port", emu.urls["socket"], "list"]) == 0
    finally:
        emu.stop()
    header, row = capsys.readouterr().out.splitlines()[:2]
    assert header.split()[6] == "channels" and row.split()[6] == "3"


def test_emulate_channels_refused_where_it_cannot_run(capsys):
    rc = bench_cli(["emulate", "--channels", "2", "--engine", "python", "--seconds", "0.1"])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "native engine" in err
    rc = bench_cli(["emulate", "--target", "soc", "--channels", "3"])
    err = capsys.readouterr().err
    assert rc == 2 and "--channels 3: the simulated SoC is built for 1, 2 or 4 cables" in err


def test_a_protocol_2_device_is_refused_in_one_line(capsys):
    """This host (protocol 3) and a device of protocol 2: one line, exit 1, nothing sent after
    HELLO."""
    old = msgs.PROTOCOL_VERSION - 1
    emu = Emulator(tcp_port=0, pty=False, identity=(old, msgs.TABLE_HASH)).start()
    try:
        rc = bench_cli(["bench", "--port", emu.urls["socket"], "set", "loop.kp=0.2"])
    finally:
        emu.stop()
    err = capsys.readouterr().err
    assert rc == 1 and len(err.strip().splitlines()) == 1
    assert f"this host speaks protocol {msgs.PROTOCOL_VERSION}" in err
    assert f"speaks protocol {old}" in err


def test_a_protocol_2_host_is_refused_in_one_line():
    """A host of protocol 2 sends its frames with version 2: the device answers each with ERROR
    VERSION naming its own version (HELLO, whatever its version, is answered) and does not act."""
    dev = Device()
    old = msgs.PROTOCOL_VERSION - 1
    # protocol 2's PARAM_SET of loop.kp: the same payload without a channel
    kp = msgs.PARAM_BY_NAME["loop.kp"]
    payload = proto.pack("PARAM_SET", param=kp.id, value=1234)
    dev.rx_bytes(0, proto.encode_frame(proto.Frame(msgs.MESSAGES["PARAM_SET"].id, 5, payload, old)))
    (reply,) = proto.FrameDecoder().feed(dev.tx_bytes(0))
    err = proto.unpack("ERROR", reply.payload)
    assert reply.seq == 5 and err["code"] == msgs.ERRORS["VERSION"]
    assert err["detail"] == msgs.PROTOCOL_VERSION and "\n" not in err["text"]
    assert err["text"] == "protocol version differs: send HELLO"
    dev.rx_bytes(0, proto.encode_frame(proto.Frame(msgs.MESSAGES["PARAM_GET"].id, 6, payload[:2])))
    (reply,) = proto.FrameDecoder().feed(dev.tx_bytes(0))
    assert proto.unpack("PARAM_VALUE", reply.payload)["value"] != 1234  # nothing was written
    dev.rx_bytes(0, proto.encode_frame(proto.Frame(msgs.MESSAGES["HELLO"].id, 7, b"", old)))
    (reply,) = proto.FrameDecoder().feed(dev.tx_bytes(0))
    assert proto.unpack("HELLO_ACK", reply.payload)["proto_version"] == msgs.PROTOCOL_VERSION


def _telemetry(sample: int, channel: int) -> proto.Frame:
    values = dict.fromkeys(
        ("time_us", "overflow", "t_ref", "t_c", "t_in", "t_out", "current", "faults", "status"), 0
    )
    values.update(sample=sample, channel=channel, t_ref=channel * 256, mu_phi=0, est_faults=0)
    return proto.Frame(msgs.MESSAGES["TELEMETRY"].id, 0, proto.pack("TELEMETRY", **values))


def test_can_telemetry_of_several_channels_keeps_each_channel_s_sample_count():
    """TELEM_A carries the channel and the sample's low 16 bits: the host rebuilds each
    channel's count across the 16-bit wrap, and a new run (a long step back) starts afresh."""
    r = proto.CanReassembler(node=1)
    samples = [65533, 65534, 65535, 65536, 65537, 0, 1]  # ... then a new run
    got = {0: [], 1: []}
    for s in samples:
        for ch in (0, 1):
            for cid, data in proto.can_encode(1, _telemetry(s, ch)):
                for f in r.feed(cid, data):
                    t = proto.unpack("TELEMETRY", f.payload)
                    got[t["channel"]].append(t["sample"])
                    assert t["t_ref"] == t["channel"] * 256
    assert got == {0: samples, 1: samples}
    assert r.stats.framing_errors == 0


def _doc_row(doc: str, link: str) -> list[str]:
    row = next(line for line in doc.splitlines() if line.startswith(f"| {link}"))
    return [c.strip() for c in row.strip("|").split("|")]


def test_the_telemetry_budget_per_channel_is_the_frames_own():
    """PROTOCOL.md's bits per channel-sample and channels at 1 kHz, recomputed from a frame this
    host encodes (serial) and the CAN frames it maps telemetry to (worst-case bit stuffing)."""
    doc = (REPO_ROOT / "firmware" / "proto" / "PROTOCOL.md").read_text()
    wire = proto.encode_frame(_telemetry(12345, 1))  # both delimiters included
    serial_bits = 10 * len(wire)  # 8N1
    uart = _doc_row(doc, "UART, 1 Mbit/s")
    assert int(uart[1]) == serial_bits
    assert uart[2].startswith(f"{1_000_000 // (serial_bits * 1000)} (")
    assert uart[3] == f"{1_000_000 // (serial_bits * 4)} Hz"

    def can_bits(n_data: int) -> int:  # base frame: 47 bits + data, stuffing over 34 + 8n
        return 44 + 8 * n_data + (34 + 8 * n_data - 1) // 4 + 3

    frames = proto.can_encode(1, _telemetry(12345, 1))
    bits = sum(can_bits(len(d)) for _, d in frames)
    row = _doc_row(doc, "CAN 2.0A, 1 Mbit/s")
    assert len(frames) == 2 and int(row[1]) == bits
    assert row[2].startswith(f"{1_000_000 // (bits * 1000)} (")
    assert re.search(r"4 channels at 1 kHz, (\d+) on the UART and (\d+) on CAN", doc).groups() == (
        str(-(-4 // (1_000_000 // (serial_bits * 1000)))),
        str(-(-4 // (1_000_000 // (bits * 1000)))),
    )
