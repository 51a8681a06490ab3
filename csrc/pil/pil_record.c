/* The host recorder of the processor-in-the-loop replay (tools/pil.py): the simulator's closed loop
 * (csrc/sim, unchanged: its one translation unit included below) with the drive's three calls in
 * the time loop (ls_drive_step, ls_drive_move_to, ls_drive_step_to) routed through wrappers that
 * write each call's inputs (pil.h's input records) and each step's outputs (pil_pack_cmd) before
 * calling the library. Built as a shared object with the extension's flags (the library
 * -ffp-contract=off, the plant -ffp-contract=fast), so that its run is the closed loop `linsense
 * simulate` runs; tools/pil.py checks that it ends where the extension's run does. Host only. */
#include <stdio.h>

#include "linsense/ls_drive.h"
#include "pil.h"

static void pil_rec_step(ls_drive *d, const ls_meas *m, ls_cmd *c);
static ls_status pil_rec_move_to(ls_drive *d, ls_pos p);
static ls_status pil_rec_step_to(ls_drive *d, ls_pos p);

#define ls_drive_step pil_rec_step
#define ls_drive_move_to pil_rec_move_to
#define ls_drive_step_to pil_rec_step_to
#include "ls_sim_all.c"
#undef ls_drive_step
#undef ls_drive_move_to
#undef ls_drive_step_to

static FILE *rec_in, *rec_out;
static int rec_err;

static void rec_write(FILE *f, const uint32_t *w, size_t n)
{
    if (fwrite(w, sizeof *w, n, f) != n) {
        rec_err = 1;
    }
}

static void pil_rec_step(ls_drive *d, const ls_meas *m, ls_cmd *c)
{
    uint32_t w[PIL_IN_WORDS] = {0}, o[PIL_OUT_WORDS];
    w[0] = PIL_EV_STEP;
    w[1] = pil_fbits(m->i_abc[0]);
    w[2] = pil_fbits(m->i_abc[1]);
    w[3] = pil_fbits(m->i_abc[2]);
    w[4] = pil_fbits(m->v_dc);
    w[5] = m->enc_valid ? 1u : 0u;
    w[6] = (uint32_t)m->enc_count;
    rec_write(rec_in, w, PIL_IN_WORDS);
    ls_drive_step(d, m, c);
    pil_pack_cmd(c, o);
    rec_write(rec_out, o, PIL_OUT_WORDS);
}

static void rec_pos(uint32_t kind, ls_pos p)
{
    uint32_t w[PIL_IN_WORDS] = {0};
    w[0] = kind;
    w[1] = (uint32_t)p.period;
    w[2] = pil_fbits(p.theta);
    rec_write(rec_in, w, PIL_IN_WORDS);
}

static ls_status pil_rec_move_to(ls_drive *d, ls_pos p)
{
    rec_pos(PIL_EV_MOVE, p);
    return ls_drive_move_to(d, p);
}

static ls_status pil_rec_step_to(ls_drive *d, ls_pos p)
{
    rec_pos(PIL_EV_STEP_TO, p);
    return ls_drive_step_to(d, p);
}

/* ls_sim_run of the closed loop, recording the drive's inputs to in_path and its outputs to out_path;
 * returns ls_sim_run's status, or -1 when a file cannot be written */
__attribute__((visibility("default"))) int pil_record(const ls_sim_cfg *cfg, ls_drive *drive, const ls_sim_cmd *cmds,
                                                      int32_t n_cmds, int64_t n_steps, const ls_sim_out *out,
                                                      ls_sim_result *res, const char *in_path, const char *out_path)
{
    int st;
    rec_err = 0;
    rec_in = fopen(in_path, "wb");
    rec_out = fopen(out_path, "wb");
    if (rec_in == NULL || rec_out == NULL) {
        if (rec_in != NULL) {
            fclose(rec_in);
        }
        if (rec_out != NULL) {
            fclose(rec_out);
        }
        return -1;
    }
    st = (int)ls_sim_run(cfg, drive, cmds, n_cmds, n_steps, out, res);
    if (fclose(rec_in) != 0 || fclose(rec_out) != 0 || rec_err) {
        return -1;
    }
    return st;
}
