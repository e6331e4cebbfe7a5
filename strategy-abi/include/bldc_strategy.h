/*
 * bldc_strategy.h: the C SDK of the bldc-drive strategy plugin ABI, version 1.2.
 *
 * One self-contained header (C99, also valid C++11 and later) for a commutation strategy
 * compiled as a shared library and loaded by the drive (the host): `drive-bench
 * --plugin`, the FMU's `strategy.plugin`, Python's `plugins=[...]`. It mirrors the Rust
 * crate `strategy-abi` (strategy-abi/src/lib.rs), which is the reference; a test of the
 * workspace (plugins/c-example/tests/layout.rs) compares the size, alignment and every
 * field offset of each struct below as a C compiler sees them with what Rust sees, so the
 * two cannot drift. docs/plugins-c.md is the guide (life of an instance, calling sequence,
 * building, debugging).
 *
 * WHAT A PLUGIN EXPORTS
 *   One symbol, BLDC_STRATEGY_ENTRY_SYMBOL ("bldc_strategy_entry"), a function taking
 *   nothing and returning a pointer to a bldc_header that lives as long as the library
 *   (a `static const` object). Everything else is reached through that header.
 *
 * VERSIONING (the append-only rule)
 *   - The first three fields of bldc_header (magic, abi_major, abi_minor) never move, in
 *     any version: a host reads them before trusting anything else.
 *   - A host loads a plugin only if the majors are equal; a different major may change
 *     anything after those three fields.
 *   - Within a major, a minor version only APPENDS: new functions at the end of
 *     bldc_vtable (the plugin states the size of its table in vtable_size, so a newer host
 *     knows which functions an older plugin lacks) and new trailing fields in the structs.
 *     Existing fields, their types, meanings and the calling conventions never change
 *     within a major. A host accepts any minor of its major and never calls a function
 *     beyond the plugin's vtable_size. 1.1 appended save and restore, 1.2 planned_change.
 *
 * UNITS
 *   Time is counted in ticks of the 50 MHz master clock: 1 tick = 20 ns, as uint64_t from
 *   the start of the run (t = 0). Speeds are mechanical rpm, currents A, voltage commands
 *   carrier counts (duty = counts / carrier_top), angles electrical degrees.
 *
 * OWNERSHIP
 *   - The header, its name and description are the plugin's static data.
 *   - An instance (bldc_instance) is the plugin's: made by create or clone, freed by
 *     destroy, exactly once each. The host never looks inside it.
 *   - Every pointer argument is the host's and valid only during the call: the config
 *     text, the drive info, inputs, sensed values, the output structs and the error
 *     buffer. A plugin must not keep any of them.
 *
 * ERRORS
 *   Calls returning int32_t return BLDC_OK, or BLDC_ERROR with a message in the
 *   bldc_error_buf, or BLDC_PANICKED when the instance is broken for good (a C plugin
 *   that detects its own corrupted state may use it). create and clone return NULL on
 *   error. Any call except destroy may fail. A failed step, or a command the host refuses
 *   (both switches of a leg on, a duty above carrier_top, a wake_at not after now), stops
 *   the run with an error naming the plugin, the call and the rule; nothing a plugin
 *   returns makes the host crash, but a plugin that writes through a bad pointer or does
 *   not return still takes the process down with it: C has no unwinding to catch.
 *   Nothing may longjmp or throw (C++) across these functions.
 *
 * THREADS
 *   The host may create an instance on one thread and call it on another, never on two
 *   threads at once; different instances may run at the same time on different threads.
 *   So: no global mutable state (keep everything in the instance), or protect it.
 */
#ifndef BLDC_STRATEGY_H
#define BLDC_STRATEGY_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The first eight bytes of every header, not NUL-terminated: "BLDCSTRT". */
#define BLDC_MAGIC_INIT {'B', 'L', 'D', 'C', 'S', 'T', 'R', 'T'}
/* ABI major version of this header: a host loads only plugins of its own major. */
#define BLDC_ABI_MAJOR 1u
/* ABI minor version of this header. 1: save and restore; 2: planned_change. */
#define BLDC_ABI_MINOR 2u
/* Name of the entry symbol (for dlsym). */
#define BLDC_STRATEGY_ENTRY_SYMBOL "bldc_strategy_entry"

/* Status codes of the vtable calls that return int32_t. */
#define BLDC_OK 0
/* The call failed; the message is in the bldc_error_buf. */
#define BLDC_ERROR 1
/* The instance is unusable (now or since an earlier call); the host stops using it. */
#define BLDC_PANICKED 2

/* Leg bits of bldc_command.legs and of planned_change: high-side switch on. */
#define BLDC_LEG_HIGH 1u
/* Low-side switch on. Both bits set would short the supply: the host refuses it. */
#define BLDC_LEG_LOW 2u
/* wake_at and planned_change's at: no instant. */
#define BLDC_NEVER UINT64_MAX

/* Master clock: ticks per second (1 tick = 20 ns). */
#define BLDC_TICKS_PER_S 50000000u

/* The size of a state the host accepts from save [bytes]: 1 MiB. */
#define BLDC_MAX_STATE_BYTES ((size_t)1 << 20)

/* Opaque instance pointer: the plugin's own struct. */
typedef void *bldc_instance;

/* Facts about the drive a strategy needs at creation. */
typedef struct bldc_drive_info {
    /* Motor pole pairs. */
    uint32_t pole_pairs;
    /* Current-sense scale [A per ADC code] (current = code * amps_per_code). */
    double amps_per_code;
    /* PWM carrier top [counts]: duty = command / carrier_top. */
    uint32_t carrier_top;
} bldc_drive_info;

/* Inputs of the chip, set by the host between steps (set_inputs). */
typedef struct bldc_inputs {
    /* Instant of the change [ticks]. */
    uint64_t now;
    /* Start input (1 = high). */
    uint8_t start;
    /* Reset input (1 = high). */
    uint8_t reset;
    /* Speed command [rpm, mechanical]. */
    double speed_ref_rpm;
} bldc_inputs;

/* What the strategy sees at a clock edge. */
typedef struct bldc_sensed {
    /* Comparator outputs u, v, w: 1 when the terminal is above the motor's neutral. */
    uint8_t zc[3];
    /* Latest shunt-current ADC code (times amps_per_code: amperes). */
    uint16_t current_code;
} bldc_sensed;

/* What the strategy returns at a clock edge. */
typedef struct bldc_command {
    /* Per leg u, v, w: BLDC_LEG_HIGH, BLDC_LEG_LOW or 0 (floating). The high side chops
       according to the host's PWM scheme. */
    uint8_t legs[3];
    /* Voltage command [carrier counts], 0..=carrier_top. */
    uint32_t duty;
    /* Comparator channels whose changes must wake the strategy (1 = watch). */
    uint8_t watch[3];
    /* Next instant the strategy must run even without a watched change [ticks], after
       now; BLDC_NEVER for none. */
    uint64_t wake_at;
} bldc_command;

/* What the strategy shows (traces, the benchmark). */
typedef struct bldc_status {
    /* 0 off, 1 aligning (and starting), 2 running, 3 gave up. */
    uint8_t mode;
    /* Commutation state (1..12 or 1..6), 0 when off or starting. */
    uint8_t state;
    /* Raw zero-crossing signal Z_d (0/1). */
    uint8_t zd;
    /* Guarded (filtered) Z_d (0/1). */
    uint8_t zdf;
    /* Inside a linear region (0/1). */
    uint8_t linear;
    /* Voltage command [carrier counts]. */
    uint32_t duty;
    /* Speed measurement [rpm]. */
    uint32_t speed_est_rpm;
    /* Current command [A]. */
    double current_ref_a;
    /* Current-PI integrator [carrier counts] (0 if the strategy has none). */
    double current_integrator;
    /* Restarts so far. */
    uint32_t restarts;
    /* Accepted zero crossings. */
    uint64_t crossings;
    /* Crossings taken by a timeout. */
    uint64_t forced_crossings;
} bldc_status;

/* The commutation table a strategy aims for (the host measures commutation angles
   against its boundaries). */
typedef struct bldc_table {
    /* 0: 120-degree six-step, 1: twelve-step. */
    uint8_t kind;
    /* Conduction angle of a twelve-step table [electrical degrees], 120 <= x < 180. */
    double conduction_deg;
} bldc_table;

/* A buffer the plugin writes an error message into: UTF-8, no NUL needed (the host reads
   len bytes), at most cap bytes: a longer message is truncated by the plugin, and a len
   above cap is itself reported as a broken rule. ptr may be NULL when the host wants no
   message. */
typedef struct bldc_error_buf {
    /* Start of the host's buffer. */
    uint8_t *ptr;
    /* Its capacity [bytes]. */
    size_t cap;
    /* Bytes written. */
    size_t len;
} bldc_error_buf;

/* The plugin's functions. None may unwind, longjmp or throw. */
typedef struct bldc_vtable {
    /* Creates an instance from the drive's whole config as TOML text (NUL-terminated
       UTF-8; the plugin reads the keys it needs and ignores the rest) and the drive
       facts; NULL on error, with the message in err. The instance starts as the chip
       does after power-up: inputs low until set_inputs. */
    bldc_instance (*create)(const char *config_toml, const bldc_drive_info *info,
                            bldc_error_buf *err);
    /* An independent copy of an instance in the same state; NULL on error. */
    bldc_instance (*clone)(bldc_instance inst, bldc_error_buf *err);
    /* Frees an instance (NULL is ignored). Cannot fail. */
    void (*destroy)(bldc_instance inst);
    /* Back to the state right after create. */
    int32_t (*reset)(bldc_instance inst, bldc_error_buf *err);
    /* The strategy's clock period [ticks], >= 1, written to out: step is called only at
       multiples of it. */
    int32_t (*clock)(bldc_instance inst, uint64_t *out, bldc_error_buf *err);
    /* Its commutation table, written to out. */
    int32_t (*table)(bldc_instance inst, bldc_table *out, bldc_error_buf *err);
    /* Sets the chip inputs (start, reset, speed command) as of inputs->now. */
    int32_t (*set_inputs)(bldc_instance inst, const bldc_inputs *inputs, bldc_error_buf *err);
    /* Runs the strategy at clock edge now [ticks]: called at least at every edge where a
       watched comparator changed since the previous step and at the edge at or after the
       last wake_at, otherwise not (between calls, the watched inputs held). Writes the
       command and the status. */
    int32_t (*step)(bldc_instance inst, uint64_t now, const bldc_sensed *sensed,
                    bldc_command *command, bldc_status *status, bldc_error_buf *err);
    /* ABI 1.1: writes the instance's dynamic state (bytes of the plugin's own format)
       into buf and its length to *len. With buf NULL, only writes the length needed and
       returns OK; with cap too small, writes the length needed and returns ERROR. A plugin
       that cannot save returns ERROR with the reason; NULL is the same as one that
       cannot. At most BLDC_MAX_STATE_BYTES. */
    int32_t (*save)(bldc_instance inst, uint8_t *buf, size_t cap, size_t *len,
                    bldc_error_buf *err);
    /* ABI 1.1: reads a state save wrote (len bytes at buf) into an instance created from
       the same config; refuses (ERROR) bytes it does not accept, and the host then drops
       the instance. */
    int32_t (*restore)(bldc_instance inst, const uint8_t *buf, size_t len,
                       bldc_error_buf *err);
    /* ABI 1.2: the next instant [ticks] at which the strategy already knows it will
       command other legs (a commutation timed by a counter), with those legs, if its
       inputs hold; BLDC_NEVER in *at for none. A hint the host reads after each step and
       restore: it ends the plant's integration step there. NULL, an error, legs no
       command could carry, legs equal to those in force or an instant not after the
       present are the same as none. The answer must be a function of the state save
       writes, as of the last step or restore (set_inputs must not change it), or a
       restored run differs from an uninterrupted one. */
    int32_t (*planned_change)(bldc_instance inst, uint64_t *at, uint8_t (*legs)[3],
                              bldc_error_buf *err);
} bldc_vtable;

/* What the entry symbol returns. */
typedef struct bldc_header {
    /* BLDC_MAGIC_INIT. */
    uint8_t magic[8];
    /* BLDC_ABI_MAJOR the plugin was built against. */
    uint32_t abi_major;
    /* BLDC_ABI_MINOR the plugin was built against. */
    uint32_t abi_minor;
    /* Strategy name, NUL-terminated UTF-8, not empty (how --strategy selects it). */
    const char *name;
    /* One-line description, NUL-terminated UTF-8. */
    const char *description;
    /* Size of the plugin's vtable [bytes]: sizeof(bldc_vtable) for this header; a whole
       number of function pointers, at least BLDC_VTABLE_1_0. The eight 1.0 functions
       (create .. step) must not be NULL; save, restore and planned_change may be. */
    uint32_t vtable_size;
    /* The functions. */
    bldc_vtable vtable;
} bldc_header;

/* The size of a 1.0 vtable [bytes]: the functions every plugin of this major has. */
#define BLDC_VTABLE_1_0 offsetof(bldc_vtable, save)

/* The entry function's type, and its declaration for the plugin to define. */
typedef const bldc_header *(*bldc_entry_fn)(void);

#if defined(_WIN32)
#define BLDC_EXPORT __declspec(dllexport)
#elif defined(__GNUC__)
#define BLDC_EXPORT __attribute__((visibility("default")))
#else
#define BLDC_EXPORT
#endif

BLDC_EXPORT const bldc_header *bldc_strategy_entry(void);

/* Writes a message into an error buffer: truncated to cap bytes (at a UTF-8 character
   boundary), len set; nothing if err or err->ptr is NULL. A helper for plugins. */
static inline void bldc_error_write(bldc_error_buf *err, const char *msg)
{
    size_t n = 0;
    if (err == NULL || err->ptr == NULL || msg == NULL) {
        return;
    }
    while (msg[n] != '\0' && n < err->cap) {
        n++;
    }
    /* Back off a continuation byte (10xxxxxx) cut from its character. */
    if (msg[n] != '\0') {
        while (n > 0 && (((unsigned char)msg[n]) & 0xC0u) == 0x80u) {
            n--;
        }
    }
    {
        size_t k;
        for (k = 0; k < n; k++) {
            err->ptr[k] = (uint8_t)msg[k];
        }
    }
    err->len = n;
}

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* BLDC_STRATEGY_H */
