/*
 * dev.h - the device side of the bench protocol (firmware/proto/PROTOCOL.md): the request
 * dispatcher, parameters, persistence, the run (waveform or streamed reference), telemetry and
 * faults, on top of the firmware's tick (fw.h).
 *
 * The board code owns the timing and the links; per port (a UART, a USB CDC endpoint, a CAN
 * controller) it feeds received bytes or CAN frames in (dev_rx_bytes, dev_rx_can), and sends what
 * dev_tx_bytes / dev_tx_can hand out, as fast as the link allows; at the tick rate it calls
 * dev_tick with the time and the output load cell's reading. Everything is integer, fixed size
 * and allocation-free: each port has a transmit buffer, and telemetry that does not fit is
 * dropped whole and counted (the telemetry's overflow counter and fault bit TX_OVERFLOW), never
 * a reply, for which room is always kept.
 *
 * Requests are answered on the port they came from; telemetry goes to the port that sent START.
 * A run ends at STOP or after START's duration; it never ends by itself only when START asks
 * for PROTO_START_DURATION_CONTINUOUS, and a duration of 0 is refused. Parameter
 * writes, PERSIST, LOAD and DEFAULTS are refused while a run is active (BUSY): the loop's register
 * words reach the FPGA at START (fw_start), so a change mid-run would not do what it says.
 * A run also ends when the port that started it sends no valid frame for
 * PROTO_HOST_WATCHDOG_TIMEOUT_MS (a crashed host or a pulled cable never leaves the motor
 * driven): the host keeps the link alive with a request every ~100 ms while it records.
 */
#ifndef BOWDEN_DEV_H
#define BOWDEN_DEV_H

#include <stdint.h>

#include "flash.h"
#include "fw.h"
#include "proto.h"
#include "proto_can.h"
#include "settings.h"

/* The device's firmware version (reported by HELLO). */
#define DEV_FW_VERSION_MAJOR 0U
#define DEV_FW_VERSION_MINOR 1U
#define DEV_FW_VERSION_PATCH 0U
/* Build id: a hash of the sources, passed by the build (-DBOWDEN_BUILD_ID=0x...). */
#ifndef BOWDEN_BUILD_ID
#define BOWDEN_BUILD_ID 0UL
#endif

#define DEV_PORTS 3U
#define DEV_PORT_SERIAL 0U
#define DEV_PORT_CAN 1U
/* Serial transmit buffer per port: 29 telemetry frames (29 ms at 1 kHz). */
#define DEV_TX_BYTES 1024U
/* CAN transmit queue per port, in frames: 32 telemetry samples. */
#define DEV_TX_CAN_FRAMES 64U
/* Streamed reference samples held: 1 s at 1 kHz, so that a host that stalls for less than that
 * (a loaded laptop, a USB latency timer) never lets the stream run dry. */
#define DEV_STREAM_LEN 1024U

/* What HELLO reports (the generated constants; a test can pose as another build). */
typedef struct {
    uint8_t proto_version;
    uint8_t fw_major;
    uint8_t fw_minor;
    uint8_t fw_patch;
    uint32_t build_id;
    uint32_t table_hash;
} dev_identity_t;

typedef struct {
    uint32_t kind; /* DEV_PORT_SERIAL or DEV_PORT_CAN */
    proto_rx_t rx;
    proto_can_rx_t can_rx;
    /* serial: a byte ring of DEV_TX_BYTES, and room past its end for a frame that reaches it:
     * encoded there in one piece, the part past the end then moved to the ring's start */
    uint8_t tx[DEV_TX_BYTES + PROTO_MAX_WIRE];
    uint32_t tx_head;
    uint32_t tx_len;
    proto_can_frame_t can_tx[DEV_TX_CAN_FRAMES]; /* CAN: frame ring */
    uint32_t can_head;
    uint32_t can_len;
    uint32_t version_errors;
    uint32_t bad_messages;
    uint32_t tx_frames;
    uint32_t tx_overflow;
} dev_port_t;

typedef struct {
    fw_t *fw;               /* the channels' firmware, fw[0 .. channels): fw[k] on bank k */
    uint32_t channels;      /* channels this device drives, [1, BOWDEN_CHANNELS_MAX] */
    uint32_t run_mask;      /* bit k: channel k runs in the active run */
    const flash_hal_t *flash;
    settings_t settings[BOWDEN_CHANNELS_MAX]; /* per channel; dev.* alike in every copy */
    dev_identity_t id;
    uint32_t config_source; /* PROTO_CONFIG_SOURCE_* */
    uint32_t dirty;         /* parameters changed since the last persist or load */
    uint32_t running;
    uint32_t owner;         /* port that started the run */
    uint32_t run_ticks;
    uint32_t run_limit;     /* 0: until STOP (START_DURATION_CONTINUOUS) */
    uint32_t faults;        /* device fault bits (PROTO_FAULTS_*, bits 4..7), latched */
    uint32_t overflow;      /* telemetry frames dropped since boot */
    uint32_t time_us;
    uint32_t host_seen_us;  /* time of the last valid frame from the run's port (host watchdog) */
    uint32_t host_timeouts; /* runs stopped because that port fell silent, since boot */
    int16_t stream[BOWDEN_CHANNELS_MAX][DEV_STREAM_LEN]; /* per channel */
    uint32_t stream_head[BOWDEN_CHANNELS_MAX];
    uint32_t stream_len[BOWDEN_CHANNELS_MAX];
    int16_t stream_last[BOWDEN_CHANNELS_MAX]; /* held when the stream runs dry */
    /* Telemetry every dev.telemetry_div samples, counted down (dev.c telemetry_due): the divisor
     * counted with, the channel's last sample, the ticks left to its next frame. */
    uint32_t tel_div[BOWDEN_CHANNELS_MAX];
    uint32_t tel_sample[BOWDEN_CHANNELS_MAX];
    uint32_t tel_left[BOWDEN_CHANNELS_MAX];
    dev_port_t ports[DEV_PORTS];
} dev_t;

/* Bind to a firmware (fw_init done) and a flash; load the saved settings (or the defaults when
 * there are none or they are rejected) and configure the firmware. Every port starts serial.
 * One channel: dev_init_channels(d, fw, 1, flash). */
void dev_init(dev_t *d, fw_t *fw, const flash_hal_t *flash);
/* The same for n channels (fw[0 .. n), each fw_init'ed on its channel's register bank: a HAL
 * whose addresses start at BOWDEN_REG_AT(k, 0)); n outside [1, BOWDEN_CHANNELS_MAX] is taken as
 * the nearest bound. The count is the board's (its build, or what it read from the FPGA). */
void dev_init_channels(dev_t *d, fw_t *fw, uint32_t n, const flash_hal_t *flash);
/* Make a port serial or CAN (clears its buffers). */
void dev_port_kind(dev_t *d, uint32_t port, uint32_t kind);

void dev_rx_bytes(dev_t *d, uint32_t port, const uint8_t *data, uint32_t n);
void dev_rx_can(dev_t *d, uint32_t port, const proto_can_frame_t *f);
/* Up to max bytes (serial) or frames (CAN) to send, oldest first; returns how many. */
uint32_t dev_tx_bytes(dev_t *d, uint32_t port, uint8_t *out, uint32_t max);
uint32_t dev_tx_can(dev_t *d, uint32_t port, proto_can_frame_t *out, uint32_t max);

/* The tick (call at fw tick_rate_hz): while a run is active, T_ref from the waveform or the
 * stream, fw_tick, and a telemetry frame every dev.telemetry_div ticks. t_out_q8 is the output
 * load cell (Q7.8 N) as the board reads it. */
void dev_tick(dev_t *d, uint32_t time_us, int32_t t_out_q8);
/* The tick of several channels: every channel of the run steps in channel order (its compensator,
 * its estimate, its register writes) and sends its own telemetry frame; t_out_q8[k] is channel
 * k's output load cell. dev_tick is this with channel 0's reading (the others' 0). */
void dev_tick_channels(dev_t *d, uint32_t time_us, const int32_t *t_out_q8);
/* The board's timer code reports a tick that came late (sets fault OVERRUN). */
void dev_overrun(dev_t *d);

#endif /* BOWDEN_DEV_H */
