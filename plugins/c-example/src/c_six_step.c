/*
 * c-six-step: a sensorless 120-degree six-step commutation written in plain C99 against
 * the bldc-drive strategy plugin ABI (strategy-abi/include/bldc_strategy.h).
 *
 * What a firmware engineer would write for a small BLDC controller:
 *   OFF -> ALIGN (hold one current vector until the rotor settles)
 *       -> RAMP  (forced commutation, constant acceleration, duty fed forward)
 *       -> RUN   (back-EMF zero crossing on the floating phase's comparator, commutation
 *                 30 degrees later by a timer, speed PI on the duty)
 *   A run of forced commutations without crossings restarts; too many restarts give up.
 *
 * Every constant is derived at create() from the drive's config (motor, power stage,
 * comparator) as commented below; nothing is tuned to the simulated plant. All state is
 * in the instance (no globals), so any number of instances can run at once, on any
 * thread, one call at a time per instance. Time is in 20 ns ticks (BLDC_TICKS_PER_S).
 */
#include "bldc_strategy.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---------------------------------------------------------------- constants */

/* The strategy's clock: 32 ticks = 0.64 us, the commutation logic's clock of the chip the
   host models (docs/model.md); the engine calls step only on its edges. */
#define CLOCK_TICKS 32u

/* A tag at the start of every instance: a pointer that does not carry it (NULL, another
   plugin's instance, a destroyed one) is refused with an error instead of being used. */
#define INSTANCE_TAG 0x43365354455031ull /* "C6STEP1" */
#define DEAD_TAG 0xDEADull

/* The saved state's format: magic and version, then the fields in a fixed order. */
static const char STATE_MAGIC[8] = {'C', '6', 'S', 'T', 'E', 'P', 'S', '1'};

enum mode { MODE_OFF = 0, MODE_ALIGN = 1, MODE_RAMP = 2, MODE_RUN = 3, MODE_GAVE_UP = 4 };

/* The 120-degree table, states 1..6 (index 0..5): {u, v, w}; state k spans
   theta_e = -30 + 60 (k-1) .. +60 degrees, and its floating phase's back-EMF crosses zero
   mid-state, rising in odd states and falling in even ones (e_x = psi w sin(theta - phi_x),
   phi = 0, 120, 240 degrees). */
#define H BLDC_LEG_HIGH
#define L BLDC_LEG_LOW
static const uint8_t SIX_STEP[6][3] = {
    {0, L, H}, /* 1: w+ v-, u floats, rising  */
    {H, L, 0}, /* 2: u+ v-, w floats, falling */
    {H, 0, L}, /* 3: u+ w-, v floats, rising  */
    {0, H, L}, /* 4: v+ w-, u floats, falling */
    {L, H, 0}, /* 5: v+ u-, w floats, rising  */
    {L, 0, H}, /* 6: w+ u-, v floats, falling */
};
#undef H
#undef L
static const uint8_t FLOATING[6] = {0, 2, 1, 0, 2, 1};

/* ---------------------------------------------------------------- the instance */

/* Constants of one drive, fixed at create (not saved: an instance is restored only into
   one created from the same config, which the saved copy of these checks). */
typedef struct params {
    uint32_t pole_pairs;
    uint32_t carrier_top;
    double supply_v;       /* power_stage.supply_v */
    double loop_r_ohm;     /* two phases, two switches and the shunt in series */
    double ke_v_s;         /* line-to-line EMF over a 60-degree window per rad/s (mech) */
    double align_duty;     /* duty that drives control.align_current_a at standstill */
    double align_ticks;    /* how long the alignment holds */
    double ramp_accel;     /* forced ramp's acceleration [rad/s^2, mechanical] */
    double ramp_current_a; /* current the ramp's duty aims for */
    double handover_rad_s; /* ramp speed at which the comparators take over */
    double limit_current_a;
    double kp;             /* speed PI [duty per rad/s] */
    double ki;             /* [duty per rad] */
    uint32_t max_restarts;
} params;

/* The dynamic state: everything save writes. */
typedef struct dyn {
    uint8_t start, reset;
    double speed_ref_rpm;
    uint8_t mode;
    uint8_t k;            /* index of the state in force, 0..5 */
    uint8_t zc_level;     /* floating comparator's last level seen */
    uint8_t zc_found;     /* the crossing of this state was taken */
    uint64_t mode_since;  /* when the mode began [ticks] */
    uint64_t ramp_n;      /* forced commutations of the ramp so far */
    uint64_t t_comm;      /* next commutation [ticks], BLDC_NEVER for none */
    uint64_t t_commuted;  /* last commutation */
    uint64_t blank_end;   /* comparator ignored until then (demagnetisation) */
    uint64_t level_since; /* when zc_level began */
    uint64_t timeout_at;  /* no crossing by then: forced commutation */
    uint64_t t_zc;        /* last accepted crossing */
    uint64_t t60[6];      /* the last six crossing intervals [ticks] */
    uint64_t t_pi;        /* next speed-PI update */
    double integrator;    /* speed PI [duty] */
    double duty;          /* fraction 0..1 */
    uint32_t restarts;
    uint32_t forced_in_row;
    uint64_t crossings, forced;
} dyn;

typedef struct c6 {
    uint64_t tag;
    params p;
    dyn d;
} c6;

/* ---------------------------------------------------------------- errors */

static void fail(bldc_error_buf *err, const char *fmt, ...)
{
    char msg[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    bldc_error_write(err, msg);
}

/* The instance behind a pointer, or NULL with an error naming the rule. */
static c6 *instance(bldc_instance inst, bldc_error_buf *err, const char *call)
{
    c6 *s = (c6 *)inst;
    if (s == NULL) {
        fail(err, "%s: null instance (rule: pass an instance create or clone returned)",
             call);
        return NULL;
    }
    if (s->tag != INSTANCE_TAG) {
        fail(err,
             "%s: not an instance of c-six-step (rule: pass an instance this plugin's create "
             "or clone returned and destroy has not freed)",
             call);
        return NULL;
    }
    return s;
}

/* ---------------------------------------------------------------- config */

/* Reads `section.key = number` from the drive's TOML. Only what this strategy needs: bare
   keys, one per line, numbers (strtod, so the C locale's decimal point); tables named by
   [headers]; everything else is skipped. Returns 1 and the value if found. */
static int toml_number(const char *toml, const char *section, const char *key, double *out)
{
    char current[128] = "";
    const char *line = toml;
    size_t klen = strlen(key);
    while (line != NULL && *line != '\0') {
        const char *end = strchr(line, '\n');
        const char *p = line;
        size_t n = end ? (size_t)(end - line) : strlen(line);
        while (p < line + n && (*p == ' ' || *p == '\t')) {
            p++;
        }
        if (*p == '[') {
            const char *q = memchr(p, ']', (size_t)(line + n - p));
            size_t m = q ? (size_t)(q - p - 1) : 0;
            if (q != NULL && m < sizeof current && p[1] != '[') {
                memcpy(current, p + 1, m);
                current[m] = '\0';
            } else {
                current[0] = '\0';
            }
        } else if (strcmp(current, section) == 0 && (size_t)(line + n - p) > klen &&
                   strncmp(p, key, klen) == 0) {
            const char *v = p + klen;
            while (*v == ' ' || *v == '\t') {
                v++;
            }
            if (*v == '=') {
                char *stop;
                double x = strtod(v + 1, &stop);
                if (stop != v + 1) {
                    *out = x;
                    return 1;
                }
            }
        }
        line = end ? end + 1 : NULL;
    }
    return 0;
}

/* One key, positive and finite (or >= 0 with allow_zero). */
static int need(const char *toml, const char *section, const char *key, int allow_zero,
                double *out, bldc_error_buf *err)
{
    char name[96];
    snprintf(name, sizeof name, "%s.%s", section, key);
    if (!toml_number(toml, section, key, out)) {
        fail(err, "create: `%s` missing or not a number (rule: the drive's config gives it)",
             name);
        return 0;
    }
    if (!isfinite(*out) || *out < 0.0 || (*out == 0.0 && !allow_zero)) {
        fail(err, allow_zero ? "create: `%s` = %g (rule: finite and >= 0)"
                             : "create: `%s` = %g (rule: finite and > 0)",
             name, *out);
        return 0;
    }
    return 1;
}

static int derive(const char *toml, const bldc_drive_info *info, params *p,
                  bldc_error_buf *err)
{
    const double pi = 3.14159265358979323846;
    double psi, r, j, tc, vs, ron, rsh, i_align, i_limit, hyst, restarts;
    if (!need(toml, "motor", "flux_linkage_wb", 0, &psi, err) ||
        !need(toml, "motor", "resistance_ohm", 0, &r, err) ||
        !need(toml, "motor", "inertia_kgm2", 0, &j, err) ||
        !need(toml, "motor", "coulomb_friction_nm", 1, &tc, err) ||
        !need(toml, "power_stage", "supply_v", 0, &vs, err) ||
        !need(toml, "power_stage", "switch_on_resistance_ohm", 1, &ron, err) ||
        !need(toml, "power_stage", "shunt_ohm", 1, &rsh, err) ||
        !need(toml, "control", "align_current_a", 0, &i_align, err) ||
        !need(toml, "control", "current_limit_a", 0, &i_limit, err) ||
        !need(toml, "control", "max_restarts", 1, &restarts, err) ||
        !need(toml, "sensing.comparator", "hysteresis_v", 1, &hyst, err)) {
        return 0;
    }
    if (info->pole_pairs == 0 || info->carrier_top == 0) {
        fail(err, "create: %s = 0 (rule: >= 1)",
             info->pole_pairs == 0 ? "pole_pairs" : "carrier_top");
        return 0;
    }
    p->pole_pairs = info->pole_pairs;
    p->carrier_top = info->carrier_top;
    p->supply_v = vs;
    /* Current path of a six-step state: in through one phase, out through another, one
       high and one low switch on, and the low rail's shunt. */
    p->loop_r_ohm = 2.0 * r + 2.0 * ron + rsh;
    /* Line-to-line EMF of two sinusoidal phases, sqrt(3) psi p w, averaged over the
       60-degree window centred on its peak (3/pi): the six-step motor constant, which is
       also its torque constant [N m/A]. */
    p->ke_v_s = 3.0 / pi * sqrt(3.0) * psi * (double)info->pole_pairs;
    p->align_duty = i_align * p->loop_r_ohm / vs;
    /* Alignment: the aligned rotor is a spring of stiffness T_peak p against the inertia;
       it swings at w_n = sqrt(ke I p / J) and Coulomb friction and the EMF's damping stop it
       within a few swings: hold four periods. */
    {
        double stiff = p->ke_v_s * i_align * (double)info->pole_pairs;
        double wn = sqrt(stiff / j);
        p->align_ticks = 4.0 * 2.0 * pi / wn * BLDC_TICKS_PER_S;
    }
    /* Ramp: the current of the alignment, accelerating at half of what its torque minus
       Coulomb friction could (margin for the rotor's lag); the duty feeds the loop's IR drop
       and the EMF of the ramp's speed forward. */
    p->ramp_current_a = i_align;
    {
        double t = p->ke_v_s * i_align - tc;
        if (t <= 0.0) {
            fail(err,
                 "create: `control.align_current_a` = %g gives no torque above Coulomb "
                 "friction %g N m (rule: ke I > motor.coulomb_friction_nm)",
                 i_align, tc);
            return 0;
        }
        p->ramp_accel = 0.5 * t / j;
    }
    /* Hand-over: the phase EMF's peak at 20 times the comparator's hysteresis, and at least
       0.2 V (the PWM edges' glitches through the comparator's front end are of that
       order), so a crossing stands out of them. */
    {
        double e = 20.0 * hyst;
        if (e < 0.2) {
            e = 0.2;
        }
        p->handover_rad_s = e / (psi * (double)info->pole_pairs);
    }
    p->limit_current_a = i_limit;
    /* Speed PI: duty to speed is K = 1/ke [rad/s per volt] times the supply, with the
       mechanical time constant tau = J R / ke^2. The PI's zero cancels that pole and the
       loop crosses over at 20 rad/s (a tenth of the slowest commutation rate it
       measures at). */
    {
        double tau = j * p->loop_r_ohm / (p->ke_v_s * p->ke_v_s);
        double gain = vs / p->ke_v_s;
        double wc = 20.0;
        p->kp = wc * tau / gain;
        p->ki = p->kp / tau;
    }
    p->max_restarts = (uint32_t)restarts;
    return 1;
}

/* ---------------------------------------------------------------- state machine */

static uint64_t secs(double s)
{
    return (uint64_t)llround(s * BLDC_TICKS_PER_S);
}

static uint64_t t60_mean(const dyn *d)
{
    uint64_t sum = 0;
    int i;
    for (i = 0; i < 6; i++) {
        sum += d->t60[i];
    }
    return sum / 6;
}

/* Speed from the last six crossing intervals (one electrical turn: the comparators'
   offsets cancel) [rad/s, mechanical]. */
static double speed_rad_s(const c6 *s)
{
    uint64_t t = t60_mean(&s->d);
    if (t == 0) {
        return 0.0;
    }
    return (3.14159265358979323846 / 3.0) / (double)s->p.pole_pairs /
           ((double)t / BLDC_TICKS_PER_S);
}

static void go_off(c6 *s, uint64_t now, uint8_t mode)
{
    s->d.mode = mode;
    s->d.mode_since = now;
    s->d.t_comm = BLDC_NEVER;
    s->d.duty = 0.0;
    s->d.integrator = 0.0;
    s->d.zc_found = 1;
}

static void begin_align(c6 *s, uint64_t now)
{
    s->d.mode = MODE_ALIGN;
    s->d.mode_since = now;
    s->d.k = 0; /* the vector of state 1: the rotor settles at the start of state 3 */
    s->d.duty = s->p.align_duty;
    s->d.t_comm = BLDC_NEVER;
    s->d.zc_found = 1;
    memset(s->d.t60, 0, sizeof s->d.t60);
}

/* Ramp time of forced commutation n from the ramp's start: theta_n = n pi/3/p at constant
   acceleration, t = sqrt(2 theta / a). */
static uint64_t ramp_time(const c6 *s, uint64_t n)
{
    double theta = (double)n * (3.14159265358979323846 / 3.0) / (double)s->p.pole_pairs;
    return secs(sqrt(2.0 * theta / s->p.ramp_accel));
}

static void commutate(c6 *s, uint64_t at)
{
    uint64_t t60 = t60_mean(&s->d);
    s->d.k = (uint8_t)((s->d.k + 1) % 6);
    s->d.t_commuted = at;
    /* Demagnetisation: the new floating phase's current freewheels through a diode and
       clamps its terminal to a rail; a quarter of a state (15 degrees) covers it. */
    s->d.blank_end = at + t60 / 4;
    s->d.timeout_at = at + t60 + t60 / 2; /* the crossing is due at t60/2 */
    s->d.zc_found = 0;
    s->d.t_comm = BLDC_NEVER;
}

static void limit_duty(c6 *s)
{
    /* The duty that drives the current limit into the loop at the present speed. */
    double top = (s->p.limit_current_a * s->p.loop_r_ohm + s->p.ke_v_s * speed_rad_s(s)) /
                 s->p.supply_v;
    if (top > 1.0) {
        top = 1.0;
    }
    if (s->d.duty > top) {
        s->d.duty = top;
    }
    if (s->d.duty < 0.0) {
        s->d.duty = 0.0;
    }
}

static void speed_pi(c6 *s)
{
    const double dt = 1e-3;
    double w_ref = s->d.speed_ref_rpm * 3.14159265358979323846 / 30.0;
    double e = w_ref - speed_rad_s(s);
    double u = s->d.integrator + s->p.kp * e;
    double before = u;
    s->d.duty = u;
    limit_duty(s);
    /* Anti-windup: integrate only while the output is not held at a limit that the
       error pushes against. */
    if (s->d.duty == before || (s->d.duty < before) != (e > 0.0)) {
        s->d.integrator += s->p.ki * e * dt;
    }
}

static void restart(c6 *s, uint64_t now)
{
    s->d.restarts++;
    if (s->d.restarts > s->p.max_restarts) {
        go_off(s, now, MODE_GAVE_UP);
    } else {
        begin_align(s, now);
    }
}

/* Runs every event due at or before now; afterwards every pending event is after now. */
static void advance(c6 *s, uint64_t now, const bldc_sensed *in)
{
    dyn *d = &s->d;
    int wants = d->start && !d->reset && d->speed_ref_rpm > 0.0;
    if (!wants) {
        if (d->mode != MODE_OFF && d->mode != MODE_GAVE_UP) {
            go_off(s, now, MODE_OFF);
        }
        if (d->reset) {
            d->mode = MODE_OFF;
            d->restarts = 0;
        }
        return;
    }
    if (d->mode == MODE_OFF) {
        begin_align(s, now);
    }
    if (d->mode == MODE_ALIGN && now >= d->mode_since + (uint64_t)s->p.align_ticks) {
        d->mode = MODE_RAMP;
        d->mode_since = now;
        d->ramp_n = 0;
        d->k = 1;       /* commutate() moves to state 3, 90 degrees ahead of the vector */
        commutate(s, now);
        d->t_comm = now + ramp_time(s, 1);
    }
    while (d->mode == MODE_RAMP && d->t_comm <= now) {
        uint64_t at = d->t_comm;
        uint64_t n = ++d->ramp_n;
        uint64_t step = ramp_time(s, n + 1) - ramp_time(s, n);
        double w = s->p.ramp_accel * (double)(at - d->mode_since) / BLDC_TICKS_PER_S;
        int i;
        for (i = 0; i < 6; i++) {
            d->t60[i] = step;
        }
        commutate(s, at);
        d->duty = (s->p.ramp_current_a * s->p.loop_r_ohm + s->p.ke_v_s * w) / s->p.supply_v;
        if (w >= s->p.handover_rad_s) {
            /* Bumpless: the PI starts from the ramp's duty; the comparators take over. */
            d->mode = MODE_RUN;
            d->mode_since = at;
            d->integrator = d->duty;
            d->t_pi = at + secs(1e-3);
            d->forced_in_row = 0;
        } else {
            d->t_comm = at + step;
        }
    }
    while (d->mode == MODE_RUN) {
        uint8_t level = in->zc[FLOATING[d->k]];
        uint8_t after = (uint8_t)((d->k % 2 == 0) ? 1 : 0); /* odd states (k even) rise */
        /* The crossing: the level after it, held for 4 us, longer than the glitches a PWM
           edge makes through the comparator's filters (about 1 us) and the 0.2 us ring. */
        const uint64_t hold = secs(4e-6);
        if (!d->zc_found && now >= d->blank_end) {
            if (d->level_since < d->blank_end || level != d->zc_level) {
                d->zc_level = level;
                d->level_since = now > d->blank_end ? now : d->blank_end;
            }
            if (d->zc_level == after && now >= d->level_since + hold) {
                uint64_t t = d->level_since;
                if (d->t_zc != 0 && t > d->t_zc) {
                    memmove(d->t60, d->t60 + 1, 5 * sizeof d->t60[0]);
                    d->t60[5] = t - d->t_zc;
                }
                d->t_zc = t;
                d->zc_found = 1;
                d->crossings++;
                d->forced_in_row = 0;
                d->t_comm = t + t60_mean(d) / 2;
            }
        }
        if (!d->zc_found && d->timeout_at <= now) {
            d->forced++;
            d->zc_found = 1;
            d->t_comm = d->timeout_at;
            if (++d->forced_in_row >= 6) {
                restart(s, d->timeout_at);
                break;
            }
        }
        if (d->t_comm <= now) {
            commutate(s, d->t_comm);
            continue; /* the new state's blanking may already be over */
        }
        break;
    }
    while (d->mode == MODE_RUN && d->t_pi <= now) {
        speed_pi(s);
        d->t_pi += secs(1e-3);
    }
}

static uint64_t earliest(uint64_t a, uint64_t b)
{
    return a < b ? a : b;
}

static void outputs(const c6 *s, uint64_t now, const bldc_sensed *in, bldc_command *c,
                    bldc_status *st)
{
    const dyn *d = &s->d;
    int on = d->mode == MODE_ALIGN || d->mode == MODE_RAMP || d->mode == MODE_RUN;
    uint64_t wake = BLDC_NEVER;
    memset(c, 0, sizeof *c);
    memset(st, 0, sizeof *st);
    if (on) {
        memcpy(c->legs, SIX_STEP[d->k], 3);
        c->duty = (uint32_t)lround(d->duty * (double)s->p.carrier_top);
        if (c->duty > s->p.carrier_top) {
            c->duty = s->p.carrier_top;
        }
    }
    if (d->mode == MODE_ALIGN) {
        wake = d->mode_since + (uint64_t)s->p.align_ticks;
    }
    if (d->mode == MODE_RAMP || d->mode == MODE_RUN) {
        wake = earliest(wake, d->t_comm);
    }
    if (d->mode == MODE_RUN) {
        wake = earliest(wake, d->t_pi);
        if (!d->zc_found) {
            wake = earliest(wake, d->timeout_at);
            if (now < d->blank_end) {
                wake = earliest(wake, d->blank_end);
            } else {
                c->watch[FLOATING[d->k]] = 1;
                if (d->zc_level == ((d->k % 2 == 0) ? 1 : 0)) {
                    wake = earliest(wake, d->level_since + secs(4e-6));
                }
            }
        }
    }
    /* Every event was handled up to now: what is pending is later (the host's rule). */
    c->wake_at = wake > now ? wake : BLDC_NEVER;
    st->mode = (uint8_t)(d->mode == MODE_RUN ? 2 : d->mode == MODE_GAVE_UP ? 3 : on ? 1 : 0);
    st->state = (uint8_t)(d->mode == MODE_RUN ? d->k + 1 : 0);
    st->zd = in->zc[FLOATING[d->k]];
    st->zdf = d->zc_level;
    st->duty = c->duty;
    st->speed_est_rpm = (uint32_t)lround(speed_rad_s(s) * 30.0 / 3.14159265358979323846);
    st->current_ref_a = d->mode == MODE_RUN ? 0.0 : on ? s->p.ramp_current_a : 0.0;
    st->restarts = d->restarts;
    st->crossings = d->crossings;
    st->forced_crossings = d->forced;
}

/* ---------------------------------------------------------------- save / restore */

typedef struct writer {
    uint8_t *buf;
    size_t cap, len;
} writer;

static void put(writer *w, const void *p, size_t n)
{
    if (w->buf != NULL && w->len + n <= w->cap) {
        memcpy(w->buf + w->len, p, n);
    }
    w->len += n;
}
static void put_u64(writer *w, uint64_t x)
{
    uint8_t b[8];
    int i;
    for (i = 0; i < 8; i++) {
        b[i] = (uint8_t)(x >> (8 * i)); /* little-endian whatever the machine */
    }
    put(w, b, 8);
}
static void put_f64(writer *w, double x)
{
    uint64_t u;
    memcpy(&u, &x, 8);
    put_u64(w, u);
}

typedef struct reader {
    const uint8_t *buf;
    size_t len, at;
    int ok;
} reader;

static uint64_t get_u64(reader *r)
{
    uint64_t x = 0;
    int i;
    if (r->at + 8 > r->len) {
        r->ok = 0;
        return 0;
    }
    for (i = 0; i < 8; i++) {
        x |= (uint64_t)r->buf[r->at + i] << (8 * i);
    }
    r->at += 8;
    return x;
}
static double get_f64(reader *r)
{
    uint64_t u = get_u64(r);
    double x;
    memcpy(&x, &u, 8);
    return x;
}

/* One order for both directions: the params (to check the config is the same), then the
   dynamic state. Small fields travel as u64 too: simple, and 200 bytes in all. */
#define FIELDS(U64, F64, U64S)                                                               \
    U64(p.pole_pairs) U64(p.carrier_top) F64(p.supply_v) F64(p.loop_r_ohm) F64(p.ke_v_s)   \
    F64(p.align_duty) F64(p.align_ticks) F64(p.ramp_accel) F64(p.ramp_current_a)            \
    F64(p.handover_rad_s) F64(p.limit_current_a) F64(p.kp) F64(p.ki) U64(p.max_restarts)   \
    U64(d.start) U64(d.reset) F64(d.speed_ref_rpm) U64(d.mode) U64(d.k) U64(d.zc_level)     \
    U64(d.zc_found) U64(d.mode_since) U64(d.ramp_n) U64(d.t_comm) U64(d.t_commuted)         \
    U64(d.blank_end) U64(d.level_since) U64(d.timeout_at) U64(d.t_zc) U64S(d.t60)           \
    U64(d.t_pi) F64(d.integrator) F64(d.duty) U64(d.restarts) U64(d.forced_in_row)          \
    U64(d.crossings) U64(d.forced)

static size_t write_state(const c6 *s, uint8_t *buf, size_t cap)
{
    writer w;
    w.buf = buf;
    w.cap = cap;
    w.len = 0;
    put(&w, STATE_MAGIC, 8);
#define W_U64(f) put_u64(&w, (uint64_t)s->f);
#define W_F64(f) put_f64(&w, s->f);
#define W_U64S(f)                                                                          \
    {                                                                                      \
        int i_;                                                                            \
        for (i_ = 0; i_ < 6; i_++) {                                                       \
            put_u64(&w, s->f[i_]);                                                         \
        }                                                                                  \
    }
    FIELDS(W_U64, W_F64, W_U64S)
#undef W_U64
#undef W_F64
#undef W_U64S
    return w.len;
}

static int read_state(c6 *s, const uint8_t *buf, size_t len, bldc_error_buf *err)
{
    c6 t;
    reader r;
    memset(&t, 0, sizeof t);
    r.buf = buf;
    r.len = len;
    r.at = 8;
    r.ok = 1;
    if (len < 8 || memcmp(buf, STATE_MAGIC, 8) != 0) {
        fail(err, "restore: %s (rule: bytes this plugin's save wrote)",
             "no c-six-step state magic");
        return 0;
    }
#define R_U64(f)                                                                           \
    {                                                                                      \
        uint64_t v_ = get_u64(&r);                                                         \
        t.f = v_;                                                                          \
        if ((uint64_t)t.f != v_) {                                                         \
            r.ok = 0; /* does not fit its field */                                         \
        }                                                                                  \
    }
#define R_F64(f) t.f = get_f64(&r);
#define R_U64S(f)                                                                          \
    {                                                                                      \
        int i_;                                                                            \
        for (i_ = 0; i_ < 6; i_++) {                                                       \
            t.f[i_] = get_u64(&r);                                                         \
        }                                                                                  \
    }
    FIELDS(R_U64, R_F64, R_U64S)
#undef R_U64
#undef R_F64
#undef R_U64S
    if (!r.ok || r.at != len) {
        fail(err, "restore: %s of %g bytes (rule: exactly what save wrote)", "a state", (double)len);
        return 0;
    }
    if (memcmp(&t.p, &s->p, sizeof t.p) != 0) {
        fail(err, "restore: %s (rule: restore into an instance created from the same config)",
             "the state was saved by an instance of another drive");
        return 0;
    }
    if (t.d.mode > MODE_GAVE_UP || t.d.k > 5 || t.d.start > 1 || t.d.reset > 1 ||
        t.d.zc_level > 1 || t.d.zc_found > 1) {
        fail(err, "restore: %s (rule: mode 0..4, state index 0..5, flags 0/1)",
             "a field out of its range");
        return 0;
    }
    s->d = t.d;
    return 1;
}

/* ---------------------------------------------------------------- the ABI functions */

static bldc_instance c6_create(const char *config_toml, const bldc_drive_info *info,
                               bldc_error_buf *err)
{
    c6 *s;
    if (config_toml == NULL || info == NULL) {
        fail(err, "create: null %s (rule: a config text and the drive info)",
             config_toml == NULL ? "config" : "drive info");
        return NULL;
    }
    s = (c6 *)calloc(1, sizeof *s);
    if (s == NULL) {
        fail(err, "create: out of memory");
        return NULL;
    }
    if (!derive(config_toml, info, &s->p, err)) {
        free(s);
        return NULL;
    }
    s->tag = INSTANCE_TAG;
    go_off(s, 0, MODE_OFF);
    return s;
}

static bldc_instance c6_clone(bldc_instance inst, bldc_error_buf *err)
{
    c6 *s = instance(inst, err, "clone");
    c6 *copy;
    if (s == NULL) {
        return NULL;
    }
    copy = (c6 *)malloc(sizeof *copy);
    if (copy == NULL) {
        fail(err, "clone: out of memory");
        return NULL;
    }
    *copy = *s;
    return copy;
}

static void c6_destroy(bldc_instance inst)
{
    c6 *s = (c6 *)inst;
    if (s != NULL && s->tag == INSTANCE_TAG) {
        s->tag = DEAD_TAG;
        free(s);
    }
}

static int32_t c6_reset(bldc_instance inst, bldc_error_buf *err)
{
    c6 *s = instance(inst, err, "reset");
    if (s == NULL) {
        return BLDC_ERROR;
    }
    memset(&s->d, 0, sizeof s->d);
    go_off(s, 0, MODE_OFF);
    return BLDC_OK;
}

static int32_t c6_clock(bldc_instance inst, uint64_t *out, bldc_error_buf *err)
{
    if (instance(inst, err, "clock") == NULL) {
        return BLDC_ERROR;
    }
    if (out == NULL) {
        fail(err, "clock: null output");
        return BLDC_ERROR;
    }
    *out = CLOCK_TICKS;
    return BLDC_OK;
}

static int32_t c6_table(bldc_instance inst, bldc_table *out, bldc_error_buf *err)
{
    if (instance(inst, err, "table") == NULL) {
        return BLDC_ERROR;
    }
    if (out == NULL) {
        fail(err, "table: null output");
        return BLDC_ERROR;
    }
    out->kind = 0;
    out->conduction_deg = 120.0;
    return BLDC_OK;
}

static int32_t c6_set_inputs(bldc_instance inst, const bldc_inputs *in, bldc_error_buf *err)
{
    c6 *s = instance(inst, err, "set_inputs");
    if (s == NULL) {
        return BLDC_ERROR;
    }
    if (in == NULL) {
        fail(err, "set_inputs: null inputs");
        return BLDC_ERROR;
    }
    if (!isfinite(in->speed_ref_rpm)) {
        fail(err, "set_inputs: %s = %g rpm (rule: finite)", "speed_ref_rpm", in->speed_ref_rpm);
        return BLDC_ERROR;
    }
    /* Latched only: the next step acts on them (planned_change must not move here). */
    s->d.start = in->start != 0;
    s->d.reset = in->reset != 0;
    s->d.speed_ref_rpm = in->speed_ref_rpm;
    return BLDC_OK;
}

static int32_t c6_step(bldc_instance inst, uint64_t now, const bldc_sensed *sensed,
                       bldc_command *command, bldc_status *status, bldc_error_buf *err)
{
    c6 *s = instance(inst, err, "step");
    if (s == NULL) {
        return BLDC_ERROR;
    }
    if (sensed == NULL || command == NULL || status == NULL) {
        fail(err, "step: null %s (rule: sensed, command and status all given)",
             sensed == NULL ? "sensed" : command == NULL ? "command" : "status");
        return BLDC_ERROR;
    }
    advance(s, now, sensed);
    outputs(s, now, sensed, command, status);
    return BLDC_OK;
}

static int32_t c6_save(bldc_instance inst, uint8_t *buf, size_t cap, size_t *len,
                       bldc_error_buf *err)
{
    c6 *s = instance(inst, err, "save");
    size_t n;
    if (s == NULL) {
        return BLDC_ERROR;
    }
    if (len == NULL) {
        fail(err, "save: null length");
        return BLDC_ERROR;
    }
    n = write_state(s, NULL, 0);
    *len = n;
    if (buf == NULL) {
        return BLDC_OK;
    }
    if (cap < n) {
        fail(err, "save: %s %g bytes (rule: ask for the length first)", "the state needs",
             (double)n);
        return BLDC_ERROR;
    }
    write_state(s, buf, cap);
    return BLDC_OK;
}

static int32_t c6_restore(bldc_instance inst, const uint8_t *buf, size_t len,
                          bldc_error_buf *err)
{
    c6 *s = instance(inst, err, "restore");
    if (s == NULL) {
        return BLDC_ERROR;
    }
    if (buf == NULL) {
        fail(err, "restore: null state");
        return BLDC_ERROR;
    }
    return read_state(s, buf, len, err) ? BLDC_OK : BLDC_ERROR;
}

static int32_t c6_planned_change(bldc_instance inst, uint64_t *at, uint8_t (*legs)[3],
                                 bldc_error_buf *err)
{
    c6 *s = instance(inst, err, "planned_change");
    if (s == NULL) {
        return BLDC_ERROR;
    }
    if (at == NULL || legs == NULL) {
        fail(err, "planned_change: null argument");
        return BLDC_ERROR;
    }
    *at = BLDC_NEVER;
    memset(*legs, 0, 3);
    /* A commutation timed by the counter: known from the saved state alone. */
    if ((s->d.mode == MODE_RAMP || s->d.mode == MODE_RUN) && s->d.t_comm != BLDC_NEVER) {
        *at = s->d.t_comm;
        memcpy(*legs, SIX_STEP[(s->d.k + 1) % 6], 3);
    }
    return BLDC_OK;
}

static const bldc_header HEADER = {
    BLDC_MAGIC_INIT,
    BLDC_ABI_MAJOR,
    BLDC_ABI_MINOR,
    "c-six-step",
    "C example plugin: sensorless 120-degree six-step (align, ramp, back-EMF crossings, "
    "speed PI), plain C99",
    (uint32_t)sizeof(bldc_vtable),
    {c6_create, c6_clone, c6_destroy, c6_reset, c6_clock, c6_table, c6_set_inputs, c6_step,
     c6_save, c6_restore, c6_planned_change},
};

BLDC_EXPORT const bldc_header *bldc_strategy_entry(void)
{
    return &HEADER;
}
