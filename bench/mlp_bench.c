/* mlp_bench [EPOCHS] [BATCH]: time per epoch of the RGB MLP trained in C
 * against the same network, loss, optimiser, batch size and data in
 * PyTorch (bench/mlp_torch.py, run from here so that both are measured in
 * one run on the same machine state). Prints both times and their ratio.
 *
 * Data: the embedded default material on the DS1 grid (912 in-plane
 * pairs), 15 % held out as in training; every epoch is a shuffled pass of
 * mini-batches plus the held-out loss, with no early stopping, on one
 * thread in both. PyTorch is skipped with a message when python3-torch is
 * not installed (`apt-get install python3-torch`). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "brdf/material.h"
#include "fit/mlp.h"
#include "fit/pseudo.h"

static const int widths[] = {2, 20, 20, 20, 20, 20, 3};

/* Run bench/mlp_torch.py (beside this source file) on the data; its time
 * per epoch in microseconds, or -1 when it was skipped or failed. */
static double torch_side(const char *data_path, int epochs, int batch)
{
    char script[4096], cmd[8400];
    snprintf(script, sizeof script, "%s", __FILE__);
    char *slash = strrchr(script, '/');
    snprintf(slash ? slash + 1 : script, sizeof script - (size_t)(slash ? slash + 1 - script : 0),
             "mlp_torch.py");
    snprintf(cmd, sizeof cmd, "/usr/bin/python3 '%s' '%s' %d %d", script, data_path, epochs,
             batch);
    FILE *py = popen(cmd, "r");
    double us = -1;
    char line[512];
    while (py && fgets(line, sizeof line, py))
        if (sscanf(line, "us_per_epoch %lf", &us) != 1)
            fputs(line, stdout);
    int st = py ? pclose(py) : -1;
    return st == 0 ? us : -1;
}

int main(int argc, char **argv)
{
    int epochs = argc > 1 ? atoi(argv[1]) : 200;
    int batch = argc > 2 ? atoi(argv[2]) : 32;
    if (epochs < 1 || batch < 1) {
        fprintf(stderr, "usage: mlp_bench [EPOCHS] [BATCH]\n");
        return 2;
    }
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open("default", &err);
    struct brdf_pair *pairs = NULL;
    int n = fit_pseudo_grid(&pairs);
    if (!m || n <= 0) {
        fprintf(stderr, "mlp_bench: %s\n", m ? "out of memory" : err.msg);
        return 1;
    }
    double *u = malloc((size_t)n * 2 * sizeof *u), *f = malloc((size_t)n * 3 * sizeof *f),
           *c = malloc((size_t)n * sizeof *c);
    brdf_material_eval(m, pairs, (size_t)n, f);
    char data_path[] = "/tmp/gonio-mlpbenchXXXXXX";
    int fd = mkstemp(data_path);
    FILE *fp = fd >= 0 ? fdopen(fd, "w") : NULL;
    if (!fp) {
        perror("mlp_bench: temporary file");
        return 1;
    }
    fprintf(fp, "theta_i,theta_r,r,g,b\n");
    for (int i = 0; i < n; i++) {
        brdf_pair_to_inplane(&pairs[i], &u[2 * i], &u[2 * i + 1]);
        c[i] = pairs[i].wi[2];
        fprintf(fp, "%.17g,%.17g,%.17g,%.17g,%.17g\n", u[2 * i], u[2 * i + 1], f[3 * i],
                f[3 * i + 1], f[3 * i + 2]);
    }
    fclose(fp);
    double torch_us = -1;

    /* C is timed before and after PyTorch and averaged, so that a change
     * of machine load during the run weighs on both sides alike. */
    struct fit_mlp net;
    struct fit_mlp_train_options o = fit_mlp_default_train_options();
    o.max_epochs = epochs;
    o.batch = batch;
    o.patience = epochs + 1; /* no early stop: a fixed number of epochs */
    struct fit_mlp_train_report r;
    double c_us[2];
    for (int run = 0; run < 2; run++) {
        if (run == 1)
            fit_mlp_free(&net);
        if (fit_mlp_init(&net, 6, widths, &err) ||
            fit_mlp_train(&net, u, f, c, (size_t)n, &o, &r, &err)) {
            fprintf(stderr, "mlp_bench: %s\n", err.msg);
            return 1;
        }
        c_us[run] = 1e6 * r.seconds / r.epochs;
        if (run == 0) {
            printf("data        %d rows (%zu train, %zu held out), batch %d, %d epochs, float64\n",
                   n, r.n_train, r.n_val, batch, r.epochs);
            printf("C           %9.1f us/epoch  (loss %.3g -> %.3g)\n", c_us[0], r.train_loss0,
                   r.train_loss);
            torch_us = torch_side(data_path, epochs, batch);
        }
    }
    printf("C again     %9.1f us/epoch\n", c_us[1]);
    double c_mean = 0.5 * (c_us[0] + c_us[1]);
    if (torch_us > 0) {
        printf("PyTorch     %9.1f us/epoch\n", torch_us);
        printf("ratio       %9.1f x (PyTorch / mean C per epoch)\n", torch_us / c_mean);
    } else {
        printf("PyTorch     skipped (python3-torch not installed or failed)\n");
    }
    unlink(data_path);
    fit_mlp_free(&net);
    free(u);
    free(f);
    free(c);
    free(pairs);
    brdf_material_free(m);
    return 0;
}
