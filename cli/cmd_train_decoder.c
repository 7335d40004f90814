/* gonio train-decoder [-o FILE] [--seed N] [--epochs N] [--threads N]:
 * rebuild the latent model's decoder (docs/latent.md) from the NBRDF
 * networks of the MERL materials minus the 10 held-out ones. The same seed
 * and epochs give a bit-identical file on the same machine. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "cli/progress.h"
#include "common/clock.h"
#include "fit/latent.h"

static void usage(FILE *out)
{
    struct latent_train_options d = latent_train_default_options();
    fprintf(out,
            "usage: gonio train-decoder [-o FILE] [--seed N] [--epochs N] [--threads N] "
            "[--quiet] [shape options]\n"
            "  -o FILE      output (default: configs/models/latent-decoder.gld)\n"
            "  --seed N     initial weights and training pairs (default %llu)\n"
            "  --epochs N   Adam steps, each over every training material (default %ld)\n"
            "  --threads N  worker threads; the result does not depend on it (default %d)\n"
            "  --z-noise SD latent noise during training (default 0)\n"
            "  --inplane F  fraction of training pairs in the incidence plane (default 0)\n"
            "  --quiet      no progress display (on stderr: a bar on a terminal)\n"
            "  --nz N --layers N --width N --samples N\n"
            "               latent size, hidden layers and units, pairs per material and\n"
            "               step (defaults %d, %d, %d, %d)\n",
            (unsigned long long)d.seed, d.steps, d.threads, d.nz, d.layers, d.width,
            d.samples_per_step);
}

struct training {
    struct progress bar;
    double t0; /* wall clock at the start, for the ETA */
};

/* latent_train's progress on the one display: epochs done, the ETA from
 * the wall time the done ones took, the running loss as the fit error.
 * On stderr only, so that stdout stays reproducible. */
static void show_progress(void *ctx, long done, long steps, double loss)
{
    struct training *t = ctx;
    double elapsed = gonio_monotonic_s() - t->t0;
    progress_show(&t->bar, &(struct progress_state){
                               .done = (size_t)done, .total = (size_t)steps, .unit = "epochs",
                               .rig_time_s = NAN, .estimate_s = NAN,
                               .eta_s = done ? elapsed * (double)(steps - done) / (double)done
                                             : NAN,
                               .fit_error = loss});
}

static int parse_num(const char *opt, const char *s, unsigned long long max,
                     unsigned long long *out)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || end == s || *end || s[0] == '-' || v > max) {
        fprintf(stderr, "gonio train-decoder: %s '%s' is not an integer in 0..%llu\n", opt, s,
                max);
        return -1;
    }
    *out = v;
    return 0;
}

int cmd_train_decoder(int argc, char **argv)
{
    static const struct option opts[] = {
        {"output", required_argument, NULL, 'o'}, {"seed", required_argument, NULL, 's'},
        {"epochs", required_argument, NULL, 'e'}, {"threads", required_argument, NULL, 't'},
        {"quiet", no_argument, NULL, 'q'},        {"help", no_argument, NULL, 'h'},
        {"nz", required_argument, NULL, 'z'},     {"width", required_argument, NULL, 'w'},
        {"layers", required_argument, NULL, 'l'}, {"samples", required_argument, NULL, 'n'},
        {"z-noise", required_argument, NULL, 'Z'}, {"inplane", required_argument, NULL, 'P'},
        {NULL, 0, NULL, 0},
    };
    struct latent_train_options o = latent_train_default_options();
    int quiet = 0;
    char out[4096];
    if (latent_decoder_default_path(out, sizeof out) < 0) {
        fprintf(stderr, "gonio train-decoder: config folder path too long\n");
        return 2;
    }
    optind = 1;
    int c;
    unsigned long long v;
    while ((c = getopt_long(argc, argv, "o:s:e:t:qhz:w:l:n:Z:P:", opts, NULL)) != -1) {
        switch (c) {
        case 'o': snprintf(out, sizeof out, "%s", optarg); break;
        case 's':
            if (parse_num("--seed", optarg, UINT64_MAX >> 1, &v) < 0)
                return 2;
            o.seed = v;
            break;
        case 'e':
            if (parse_num("--epochs", optarg, 100000000, &v) < 0)
                return 2;
            if (v == 0) {
                fprintf(stderr, "gonio train-decoder: --epochs must be at least 1\n");
                return 2;
            }
            o.steps = (long)v;
            break;
        case 't':
            if (parse_num("--threads", optarg, 64, &v) < 0)
                return 2;
            if (v == 0) {
                fprintf(stderr, "gonio train-decoder: --threads must be 1..64\n");
                return 2;
            }
            o.threads = (int)v;
            break;
        case 'z':
        case 'w':
        case 'l':
        case 'n':
            /* shape and batch: latent_train range-checks them */
            if (parse_num("shape option", optarg, 100000, &v) < 0)
                return 2;
            *(c == 'z' ? &o.nz : c == 'w' ? &o.width : c == 'l' ? &o.layers
                                                     : &o.samples_per_step) = (int)v;
            break;
        case 'Z': {
            char *end;
            o.z_noise = strtod(optarg, &end);
            if (end == optarg || *end || !(o.z_noise >= 0 && o.z_noise < 10)) {
                fprintf(stderr, "gonio train-decoder: --z-noise '%s' must be in [0, 10)\n",
                        optarg);
                return 2;
            }
            break;
        }
        case 'P': {
            char *end;
            o.inplane = strtod(optarg, &end);
            if (end == optarg || *end || !(o.inplane >= 0 && o.inplane <= 1)) {
                fprintf(stderr, "gonio train-decoder: --inplane '%s' must be in [0, 1]\n",
                        optarg);
                return 2;
            }
            break;
        }
        case 'q': quiet = 1; break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind != argc) {
        fprintf(stderr, "gonio train-decoder: unexpected argument '%s'\n", argv[optind]);
        usage(stderr);
        return 2;
    }
    struct gonio_err err = {0};
    char **names = NULL;
    size_t n = 0;
    if (latent_default_training_set(&names, &n, &err) < 0) {
        fprintf(stderr, "gonio train-decoder: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    struct training t = {.t0 = gonio_monotonic_s()};
    progress_init(&t.bar, "train-decoder", quiet);
    show_progress(&t, 0, o.steps, NAN);
    o.on_progress = show_progress;
    o.progress_ctx = &t;
    latent_decoder *d = NULL;
    int rc = latent_train((const char *const *)names, n, &o, &d, &err);
    progress_end(&t.bar);
    latent_names_free(names, n);
    if (rc == 0)
        rc = latent_decoder_save(d, out, &err);
    if (rc < 0) {
        latent_decoder_free(d);
        fprintf(stderr, "gonio train-decoder: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    printf("wrote %s (%zu training materials, nz %d, seed %llu, %ld epochs, crc %08x)\n", out,
           latent_decoder_n_materials(d), latent_decoder_nz(d), (unsigned long long)o.seed,
           o.steps, (unsigned)latent_decoder_crc(d));
    latent_decoder_free(d);
    return 0;
}
