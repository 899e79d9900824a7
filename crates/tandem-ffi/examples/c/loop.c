/*
 * tandem's controller from C: the dual-UR5 scenario's NN law, started on the scenario's start
 * state and ticked 1000 times with that state held (a stand-in for a robot's readings), the
 * torques printed each tick with %.17g (exactly: tests/c_examples.rs compares them with the
 * Rust tick bit for bit) and the record's z1 at the end; then a bad reading, refused with its
 * message, and a valid tick after it.
 *
 * Build (from the repository root, after `cargo build --release -p tandem-ffi`):
 *   cc -std=c99 -O2 -I crates/tandem-ffi/include crates/tandem-ffi/examples/c/loop.c \
 *      target/release/libtandem_ffi.a -lpthread -ldl -lm -o loop
 *   ./loop [PRESET [LAW [TICKS]]]      (defaults: dual-ur5 nn 1000)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "tandem.h"

/* On a status other than TANDEM_OK: print the call, the status and the message, and fail. */
#define CHECK(call)                                                                 \
    do {                                                                            \
        TandemStatus st_ = (call);                                                  \
        if (st_ != TANDEM_OK) {                                                     \
            fprintf(stderr, "%s: %s: %s\n", #call, tandem_status_name(st_),         \
                    tandem_last_error());                                           \
            goto fail;                                                              \
        }                                                                           \
    } while (0)

int main(int argc, char **argv) {
    const char *preset = argc > 1 ? argv[1] : "dual-ur5";
    const char *law = argc > 2 ? argv[2] : "nn";
    int ticks = argc > 3 ? atoi(argv[3]) : 1000;
    TandemController *h = NULL;
    double *q = NULL, *qd = NULL, *w = NULL, *tau = NULL, *z1 = NULL;
    size_t n_q = 0, n_arms = 0, wd = 0, nw = 0, nz = 0;
    double dt = 0.0;
    int rc = 1;

    CHECK(tandem_controller_new_preset(preset, law, &h));
    CHECK(tandem_n_q(h, &n_q));
    CHECK(tandem_n_arms(h, &n_arms));
    CHECK(tandem_wrench_dim(h, &wd));
    CHECK(tandem_control_period(h, &dt));
    nw = n_arms * wd;
    printf("scenario %s law %s tandem %s: %zu joints, %zu arms, %zu wrench channels each, "
           "period %g s\n",
           preset, law, tandem_version(), n_q, n_arms, wd, dt);

    q = calloc(n_q, sizeof *q);
    qd = calloc(n_q, sizeof *qd);
    w = calloc(nw, sizeof *w);
    tau = calloc(n_q, sizeof *tau);
    if (!q || !qd || !w || !tau) goto fail;
    CHECK(tandem_start_state(h, q, n_q, qd, n_q, w, nw));

    /* Start once with the first readings, then tick every period from the start's time on. */
    CHECK(tandem_start(h, 0.0, q, n_q, qd, n_q, w, nw));
    for (int k = 0; k < ticks; ++k) {
        double t = k * dt;
        /* Here a robot would be read (q, qd, w) with the previous tau held. */
        CHECK(tandem_tick(h, t, q, n_q, qd, n_q, w, nw, tau, n_q));
        /* ... and tau sent. */
        printf("tau %d", k);
        for (size_t i = 0; i < n_q; ++i) printf(" %.17g", tau[i]);
        printf("\n");
    }

    /* The record: ask the length, then read. */
    CHECK(tandem_record_vector(h, "z1", NULL, 0, &nz));
    z1 = calloc(nz, sizeof *z1);
    if (!z1) goto fail;
    CHECK(tandem_record_vector(h, "z1", z1, nz, NULL));
    printf("z1");
    for (size_t i = 0; i < nz; ++i) printf(" %.17g", z1[i]);
    printf("\n");

    /* A bad reading is refused with a message naming it; the controller is unchanged and the
     * next valid tick works. */
    {
        double saved = q[1];
        TandemStatus st;
        q[1] = NAN;
        st = tandem_tick(h, ticks * dt, q, n_q, qd, n_q, w, nw, tau, n_q);
        printf("refused: %s: %s\n", tandem_status_name(st), tandem_last_error());
        q[1] = saved;
        CHECK(tandem_tick(h, ticks * dt, q, n_q, qd, n_q, w, nw, tau, n_q));
        printf("next tick: ok\n");
    }
    rc = 0;
fail:
    free(q);
    free(qd);
    free(w);
    free(tau);
    free(z1);
    tandem_controller_free(h);
    return rc;
}
