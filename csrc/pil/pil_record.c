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

/* closed-loop processor in the loop (pil_remote): the steps are the firmware's, under QEMU, through
 * two named pipes (to_fw: the input records; from_fw: its packed outputs) */
static FILE *to_fw, *from_fw;

static void unpack_cmd(const uint32_t w[PIL_OUT_WORDS], ls_cmd *c)
{
    memset(c, 0, sizeof *c);
    c->duty[0] = pil_bitsf(w[0]);
    c->duty[1] = pil_bitsf(w[1]);
    c->duty[2] = pil_bitsf(w[2]);
    c->enable = w[3] != 0u;
    c->fault = w[4];
    c->mode = (ls_mode)w[5];
    c->pos_fb.period = (int32_t)w[6];
    c->pos_fb.theta = pil_bitsf(w[7]);
    c->pos_est.period = (int32_t)w[8];
    c->pos_est.theta = pil_bitsf(w[9]);
    c->pos_ref.period = (int32_t)w[10];
    c->pos_ref.theta = pil_bitsf(w[11]);
    c->v_est = pil_bitsf(w[12]);
    c->v_fb = pil_bitsf(w[13]);
    c->f_load_est = pil_bitsf(w[14]);
    c->err_sig = pil_bitsf(w[15]);
    c->err_valid = w[16] != 0u;
    c->hf_level = pil_bitsf(w[17]);
    c->psi_comp = pil_bitsf(w[18]);
    c->i_dq[0] = pil_bitsf(w[19]);
    c->i_dq[1] = pil_bitsf(w[20]);
    c->i_dq_ref[0] = pil_bitsf(w[21]);
    c->i_dq_ref[1] = pil_bitsf(w[22]);
    c->v_dq[0] = pil_bitsf(w[23]);
    c->v_dq[1] = pil_bitsf(w[24]);
    c->v_hf = pil_bitsf(w[25]);
    c->cal_index = w[26];
    c->cal_done = w[27] != 0u;
    c->psi_cal = pil_bitsf(w[28]);
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
    if (to_fw != NULL) { /* the firmware's step; the host's drive only tells the plant its mode */
        rec_write(to_fw, w, PIL_IN_WORDS);
        if (fflush(to_fw) != 0 || fread(o, sizeof o[0], PIL_OUT_WORDS, from_fw) != PIL_OUT_WORDS) {
            rec_err = 1;
            memset(o, 0, sizeof o);
            o[4] = LS_FAULT_CONFIG;
        }
        unpack_cmd(o, c);
        d->mode = c->mode == LS_MODE_STARTUP ? LS_MODE_OFF : c->mode;
    } else {
        ls_drive_step(d, m, c);
        pil_pack_cmd(c, o);
    }
    rec_write(rec_out, o, PIL_OUT_WORDS);
}

static void rec_pos(uint32_t kind, ls_pos p)
{
    uint32_t w[PIL_IN_WORDS] = {0};
    w[0] = kind;
    w[1] = (uint32_t)p.period;
    w[2] = pil_fbits(p.theta);
    rec_write(rec_in, w, PIL_IN_WORDS);
    if (to_fw != NULL) {
        rec_write(to_fw, w, PIL_IN_WORDS);
    }
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

/* pil_record with the firmware under QEMU in the loop: each step's inputs go to the pipe to_path,
 * its outputs come from from_path (the firmware's replay in its closed-loop build, PIL_REMOTE) */
__attribute__((visibility("default"))) int pil_remote(const ls_sim_cfg *cfg, ls_drive *drive, const ls_sim_cmd *cmds,
                                                      int32_t n_cmds, int64_t n_steps, const ls_sim_out *out,
                                                      ls_sim_result *res, const char *in_path, const char *out_path,
                                                      const char *to_path, const char *from_path)
{
    int st;
    to_fw = fopen(to_path, "wb");
    from_fw = to_fw == NULL ? NULL : fopen(from_path, "rb");
    if (to_fw == NULL || from_fw == NULL) {
        if (to_fw != NULL) {
            fclose(to_fw); /* (the other pipe failed to open: none left open, none reused) */
        }
        to_fw = from_fw = NULL;
        return -1;
    }
    st = pil_record(cfg, drive, cmds, n_cmds, n_steps, out, res, in_path, out_path);
    fclose(to_fw); /* the firmware reads the end and exits */
    fclose(from_fw);
    to_fw = from_fw = NULL;
    return st;
}
