/*
 * A test fixture in C that breaks the plugin ABI's rules the way a C plugin can, so the
 * tests can show that the host refuses each with an error naming the plugin and the rule,
 * never a crash. The environment variable BLDC_TEST_MISBEHAVE chooses the fault, read
 * when the entry symbol is called (header faults) or at create (call faults):
 *   c-foreign-header  the entry returns a pointer to something that is not a header
 *   c-null-name       the header's name is a null pointer
 *   c-null-function   the vtable's step is a null pointer
 *   c-vtable-mid-pointer  vtable_size ends inside a function pointer
 *   c-null-instance   create returns NULL and writes no message
 *   c-long-error      step fails with a message longer than the buffer, not
 *                     NUL-terminated, and claims a len above cap
 *   c-shoot-through   step commands both switches of leg u on (from tick 64000)
 *   c-wake-past       step asks to be woken at a tick in the past (from tick 64000)
 * anything else: a strategy that keeps the bridge off. No global mutable state.
 */
#include "bldc_strategy.h"

#include <stdlib.h>
#include <string.h>

#define TAG 0x4D49534245484156ull /* "MISBEHAV" */

typedef struct fixture {
    uint64_t tag;
    char mode[32];
} fixture;

static const char *mode(void)
{
    const char *m = getenv("BLDC_TEST_MISBEHAVE");
    return m ? m : "";
}

static int is(const fixture *f, const char *m)
{
    return strcmp(f->mode, m) == 0;
}

static fixture *get(bldc_instance inst, bldc_error_buf *err)
{
    fixture *f = (fixture *)inst;
    if (f == NULL || f->tag != TAG) {
        bldc_error_write(err, "not an instance of c-misbehaving (rule: pass one it created)");
        return NULL;
    }
    return f;
}

static bldc_instance create(const char *config, const bldc_drive_info *info,
                            bldc_error_buf *err)
{
    fixture *f;
    (void)config;
    (void)info;
    if (strcmp(mode(), "c-null-instance") == 0) {
        return NULL; /* and no message */
    }
    f = (fixture *)calloc(1, sizeof *f);
    if (f == NULL) {
        bldc_error_write(err, "out of memory");
        return NULL;
    }
    f->tag = TAG;
    strncpy(f->mode, mode(), sizeof f->mode - 1);
    return f;
}

static bldc_instance clone(bldc_instance inst, bldc_error_buf *err)
{
    fixture *f = get(inst, err);
    fixture *c;
    if (f == NULL) {
        return NULL;
    }
    c = (fixture *)malloc(sizeof *c);
    if (c != NULL) {
        *c = *f;
    }
    return c;
}

static void destroy(bldc_instance inst)
{
    fixture *f = (fixture *)inst;
    if (f != NULL && f->tag == TAG) {
        f->tag = 0;
        free(f);
    }
}

static int32_t reset(bldc_instance inst, bldc_error_buf *err)
{
    return get(inst, err) ? BLDC_OK : BLDC_ERROR;
}

static int32_t clock_(bldc_instance inst, uint64_t *out, bldc_error_buf *err)
{
    if (get(inst, err) == NULL) {
        return BLDC_ERROR;
    }
    *out = 32;
    return BLDC_OK;
}

static int32_t table(bldc_instance inst, bldc_table *out, bldc_error_buf *err)
{
    if (get(inst, err) == NULL) {
        return BLDC_ERROR;
    }
    out->kind = 0;
    out->conduction_deg = 120.0;
    return BLDC_OK;
}

static int32_t set_inputs(bldc_instance inst, const bldc_inputs *in, bldc_error_buf *err)
{
    (void)in;
    return get(inst, err) ? BLDC_OK : BLDC_ERROR;
}

static int32_t step(bldc_instance inst, uint64_t now, const bldc_sensed *sensed,
                    bldc_command *c, bldc_status *st, bldc_error_buf *err)
{
    fixture *f = get(inst, err);
    (void)sensed;
    if (f == NULL) {
        return BLDC_ERROR;
    }
    memset(c, 0, sizeof *c);
    memset(st, 0, sizeof *st);
    c->wake_at = now + 32000;
    if (now < 64000) {
        return BLDC_OK;
    }
    if (is(f, "c-long-error") && err != NULL && err->ptr != NULL) {
        /* Fills the whole buffer with 'x', no NUL anywhere, and claims more. */
        memset(err->ptr, 'x', err->cap);
        err->len = err->cap + 100;
        return BLDC_ERROR;
    }
    if (is(f, "c-shoot-through")) {
        c->legs[0] = BLDC_LEG_HIGH | BLDC_LEG_LOW;
        c->legs[1] = BLDC_LEG_LOW;
    }
    if (is(f, "c-wake-past")) {
        c->wake_at = now - 1000;
    }
    return BLDC_OK;
}

static int32_t save(bldc_instance inst, uint8_t *buf, size_t cap, size_t *len,
                    bldc_error_buf *err)
{
    if (get(inst, err) == NULL) {
        return BLDC_ERROR;
    }
    *len = 2;
    if (buf != NULL) {
        if (cap < 2) {
            return BLDC_ERROR;
        }
        memcpy(buf, "ok", 2);
    }
    return BLDC_OK;
}

static int32_t restore(bldc_instance inst, const uint8_t *buf, size_t len,
                       bldc_error_buf *err)
{
    if (get(inst, err) == NULL) {
        return BLDC_ERROR;
    }
    if (len != 2 || memcmp(buf, "ok", 2) != 0) {
        bldc_error_write(err, "not a state of c-misbehaving");
        return BLDC_ERROR;
    }
    return BLDC_OK;
}

#define HEADER(name, size, step_fn)                                                        \
    {                                                                                      \
        BLDC_MAGIC_INIT, BLDC_ABI_MAJOR, BLDC_ABI_MINOR, name, "C test fixture",           \
            (uint32_t)(size),                                                              \
        {                                                                                  \
            create, clone, destroy, reset, clock_, table, set_inputs, step_fn, save,       \
                restore, NULL                                                              \
        }                                                                                  \
    }

static const bldc_header GOOD = HEADER("c-misbehaving", sizeof(bldc_vtable), step);
static const bldc_header NULL_NAME = HEADER(NULL, sizeof(bldc_vtable), step);
static const bldc_header NULL_FUNCTION = HEADER("c-misbehaving", sizeof(bldc_vtable), NULL);
static const bldc_header MID_POINTER =
    HEADER("c-misbehaving", BLDC_VTABLE_1_0 + sizeof(void *) / 2, step);
/* Something else entirely: text where a header should be. */
static const char FOREIGN[64] = "this is not a bldc_header, just text in the library";

BLDC_EXPORT const bldc_header *bldc_strategy_entry(void)
{
    const char *m = mode();
    if (strcmp(m, "c-foreign-header") == 0) {
        return (const bldc_header *)(const void *)FOREIGN;
    }
    if (strcmp(m, "c-null-name") == 0) {
        return &NULL_NAME;
    }
    if (strcmp(m, "c-null-function") == 0) {
        return &NULL_FUNCTION;
    }
    if (strcmp(m, "c-vtable-mid-pointer") == 0) {
        return &MID_POINTER;
    }
    return &GOOD;
}
