/* The ABI's layout and constants as a C compiler sees them through bldc_strategy.h: a
   table of (name, value) read by tests/layout.rs and compared with Rust's offset_of!,
   size_of and align_of of the strategy-abi structs. C99: alignment is measured as the
   offset of a member after one char. */
#include "bldc_strategy.h"

typedef struct bldc_layout_entry {
    const char *name;
    uint64_t value;
} bldc_layout_entry;

#define ALIGN_HELPER(T) struct align_##T { char c; T x; }
ALIGN_HELPER(bldc_drive_info);
ALIGN_HELPER(bldc_inputs);
ALIGN_HELPER(bldc_sensed);
ALIGN_HELPER(bldc_command);
ALIGN_HELPER(bldc_status);
ALIGN_HELPER(bldc_table);
ALIGN_HELPER(bldc_error_buf);
ALIGN_HELPER(bldc_vtable);
ALIGN_HELPER(bldc_header);

#define TYPE(T, R) {R ".size", sizeof(T)}, {R ".align", offsetof(struct align_##T, x)}
#define FIELD(T, R, f) {R "." #f, offsetof(T, f)}

static const bldc_layout_entry TABLE[] = {
    TYPE(bldc_drive_info, "DriveInfo"),
    FIELD(bldc_drive_info, "DriveInfo", pole_pairs),
    FIELD(bldc_drive_info, "DriveInfo", amps_per_code),
    FIELD(bldc_drive_info, "DriveInfo", carrier_top),
    TYPE(bldc_inputs, "Inputs"),
    FIELD(bldc_inputs, "Inputs", now),
    FIELD(bldc_inputs, "Inputs", start),
    FIELD(bldc_inputs, "Inputs", reset),
    FIELD(bldc_inputs, "Inputs", speed_ref_rpm),
    TYPE(bldc_sensed, "CSensed"),
    FIELD(bldc_sensed, "CSensed", zc),
    FIELD(bldc_sensed, "CSensed", current_code),
    TYPE(bldc_command, "CCommand"),
    FIELD(bldc_command, "CCommand", legs),
    FIELD(bldc_command, "CCommand", duty),
    FIELD(bldc_command, "CCommand", watch),
    FIELD(bldc_command, "CCommand", wake_at),
    TYPE(bldc_status, "CStatus"),
    FIELD(bldc_status, "CStatus", mode),
    FIELD(bldc_status, "CStatus", state),
    FIELD(bldc_status, "CStatus", zd),
    FIELD(bldc_status, "CStatus", zdf),
    FIELD(bldc_status, "CStatus", linear),
    FIELD(bldc_status, "CStatus", duty),
    FIELD(bldc_status, "CStatus", speed_est_rpm),
    FIELD(bldc_status, "CStatus", current_ref_a),
    FIELD(bldc_status, "CStatus", current_integrator),
    FIELD(bldc_status, "CStatus", restarts),
    FIELD(bldc_status, "CStatus", crossings),
    FIELD(bldc_status, "CStatus", forced_crossings),
    TYPE(bldc_table, "CTable"),
    FIELD(bldc_table, "CTable", kind),
    FIELD(bldc_table, "CTable", conduction_deg),
    TYPE(bldc_error_buf, "ErrorBuf"),
    FIELD(bldc_error_buf, "ErrorBuf", ptr),
    FIELD(bldc_error_buf, "ErrorBuf", cap),
    FIELD(bldc_error_buf, "ErrorBuf", len),
    TYPE(bldc_vtable, "VTable"),
    FIELD(bldc_vtable, "VTable", create),
    FIELD(bldc_vtable, "VTable", clone),
    FIELD(bldc_vtable, "VTable", destroy),
    FIELD(bldc_vtable, "VTable", reset),
    FIELD(bldc_vtable, "VTable", clock),
    FIELD(bldc_vtable, "VTable", table),
    FIELD(bldc_vtable, "VTable", set_inputs),
    FIELD(bldc_vtable, "VTable", step),
    FIELD(bldc_vtable, "VTable", save),
    FIELD(bldc_vtable, "VTable", restore),
    FIELD(bldc_vtable, "VTable", planned_change),
    TYPE(bldc_header, "Header"),
    FIELD(bldc_header, "Header", magic),
    FIELD(bldc_header, "Header", abi_major),
    FIELD(bldc_header, "Header", abi_minor),
    FIELD(bldc_header, "Header", name),
    FIELD(bldc_header, "Header", description),
    FIELD(bldc_header, "Header", vtable_size),
    FIELD(bldc_header, "Header", vtable),
    /* Constants. */
    {"ABI_MAJOR", BLDC_ABI_MAJOR},
    {"ABI_MINOR", BLDC_ABI_MINOR},
    {"OK", BLDC_OK},
    {"ERROR", BLDC_ERROR},
    {"PANICKED", BLDC_PANICKED},
    {"LEG_HIGH", BLDC_LEG_HIGH},
    {"LEG_LOW", BLDC_LEG_LOW},
    {"MAX_STATE_BYTES", BLDC_MAX_STATE_BYTES},
    {"VTABLE_1_0", BLDC_VTABLE_1_0},
    {"NEVER", BLDC_NEVER},
    {"sizeof(bldc_instance)", sizeof(bldc_instance)},
};

static const uint8_t MAGIC[8] = BLDC_MAGIC_INIT;

const bldc_layout_entry *bldc_layout_table(size_t *count)
{
    *count = sizeof TABLE / sizeof TABLE[0];
    return TABLE;
}

const uint8_t *bldc_layout_magic(void)
{
    return MAGIC;
}

const char *bldc_layout_entry_symbol(void)
{
    return BLDC_STRATEGY_ENTRY_SYMBOL;
}
