/* gonio-sim: the simulated gonioreflectometer as its own process, serving
 * the rig's Modbus bus (docs/gonio-sim.md). A thin shell: options, scene,
 * signals; sim/modbus_server.c does the rest. */
#include <getopt.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/material.h"
#include "common/err.h"
#include "common/version.h"
#include "rig/rig.h"
#include "sim/modbus_server.h"
#include "sim/scene.h"

static volatile sig_atomic_t stop_flag, hangup_flag;

static void on_signal(int sig)
{
    if (sig == SIGUSR1)
        hangup_flag = 1;
    else
        stop_flag = 1;
}

static void usage(FILE *out)
{
    fprintf(out,
            "usage: gonio-sim [--scene NAME|FILE] [--material SPEC] [--rig NAME|FILE]\n"
            "                 [--time-scale K] [--steps-per-deg N] [--in-pos-deg D]\n"
            "                 [--link PATH]\n"
            "                 [--tcp 127.0.0.1:PORT] [--trace] [--check]\n"
            "                 [--stall SLAVE:DEG] [--overload SLAVE:DEG] [--delay SLAVE:MS]\n"
            "                 [--stats FILE] [--baud N] [--tcp-latency MS]\n"
            "       gonio-sim --version\n"
            "  Serves the rig's Modbus bus (docs/protocol-modbus.md) as RTU on a new\n"
            "  pseudo-terminal, whose path is the first line on stdout, and with --tcp\n"
            "  also as Modbus TCP (second line: 'tcp HOST:PORT'; PORT 0 picks one).\n"
            "  Simulated time runs K times faster than wall time (default 1). The drives\n"
            "  report IN-POS within D deg of their target (default 0.05).\n"
            "  --check prints the resolved setup and exits. --stall and --overload put an\n"
            "  obstacle on an axis: moves across it halt there, still moving (stall) or\n"
            "  with alarm 0x30 (overload). --delay makes a slave answer MS ms late.\n"
            "  --stats writes, at exit, the exchanges, the faults injected and each axis's\n"
            "  commanded and reached range as JSON.\n"
            "  --baud makes each RTU exchange take its frames' time on a serial line at N\n"
            "  baud, --tcp-latency each TCP reply MS ms, both in rig time. SIGUSR1 closes\n"
            "  every TCP connection (a network drop).\n"
            "  What is served is also announced on stderr.\n");
}

static int parse_positive(const char *opt, const char *s, double *out)
{
    char *end;
    double v = strtod(s, &end);
    if (*end || !(v > 0) || v > 1e9) {
        fprintf(stderr, "gonio-sim: %s '%s': expected a positive number\n", opt, s);
        return -1;
    }
    *out = v;
    return 0;
}

int main(int argc, char **argv)
{
    static const struct option opts[] = {
        {"baud", required_argument, NULL, 'b'},      {"tcp-latency", required_argument, NULL, 'L'},
        {"scene", required_argument, NULL, 's'},      {"material", required_argument, NULL, 'm'},
        {"rig", required_argument, NULL, 'r'},        {"time-scale", required_argument, NULL, 'k'},
        {"steps-per-deg", required_argument, NULL, 'n'}, {"link", required_argument, NULL, 'l'},
        {"tcp", required_argument, NULL, 't'},        {"trace", no_argument, NULL, 'T'},
        {"check", no_argument, NULL, 'c'},            {"help", no_argument, NULL, 'h'},
        {"stall", required_argument, NULL, 'S'},      {"overload", required_argument, NULL, 'O'},
        {"delay", required_argument, NULL, 'D'},     {"stats", required_argument, NULL, 'X'},
        {"in-pos-deg", required_argument, NULL, 'i'},
        {"version", no_argument, NULL, 'V'},
        {NULL, 0, NULL, 0},
    };
    const char *scene_name = "ideal", *material_spec = NULL, *rig_name = NULL, *link = NULL,
               *tcp = NULL, *stats = NULL;
    /* IN-POS band: the AZ's initial 1.8 deg at the motor (docs/gonio-sim.md)
     * through the 36:1 reduction that 100 steps/deg at 1000 steps/rev means. */
    struct msim_cfg cfg = {.time_scale = 1.0, .steps_per_deg = 100.0, .in_pos_deg = 0.05};
    int check = 0, c, n_jams = 0;
    struct {
        enum msim_jam_kind kind;
        int slave;
        double deg;
    } jams[4]; /* faults: --stall, --overload, --delay (kind NONE) */
    while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        switch (c) {
        case 's': scene_name = optarg; break;
        case 'm': material_spec = optarg; break;
        case 'r': rig_name = optarg; break;
        case 'k':
            if (parse_positive("--time-scale", optarg, &cfg.time_scale) < 0)
                return 2;
            break;
        case 'n':
            if (parse_positive("--steps-per-deg", optarg, &cfg.steps_per_deg) < 0)
                return 2;
            break;
        case 'i':
            if (parse_positive("--in-pos-deg", optarg, &cfg.in_pos_deg) < 0)
                return 2;
            break;
        case 'l': link = optarg; break;
        case 't': tcp = optarg; break;
        case 'T': cfg.trace = 1; break;
        case 'X': stats = optarg; break;
        case 'b': {
            double baud;
            if (parse_positive("--baud", optarg, &baud) < 0)
                return 2;
            if (baud != floor(baud)) {
                fprintf(stderr, "gonio-sim: --baud '%s': expected a whole number\n", optarg);
                return 2;
            }
            cfg.baud = (long)baud;
            break;
        }
        case 'L':
            if (parse_positive("--tcp-latency", optarg, &cfg.tcp_latency_s) < 0)
                return 2;
            cfg.tcp_latency_s *= 1e-3;
            break;
        case 'c': check = 1; break;
        case 'S':
        case 'D':
        case 'O': {
            char *end;
            long slave = strtol(optarg, &end, 10);
            double deg = *end == ':' ? strtod(end + 1, &end) : NAN;
            if (*end || !isfinite(deg) || n_jams == 4) {
                fprintf(stderr, "gonio-sim: --%s '%s': expected SLAVE:%s\n",
                        c == 'S' ? "stall" : c == 'O' ? "overload" : "delay", optarg,
                        c == 'D' ? "MS" : "DEG");
                return 2;
            }
            jams[n_jams].kind = c == 'S' ? MSIM_JAM_STALL
                                : c == 'O' ? MSIM_JAM_OVERLOAD
                                           : MSIM_JAM_NONE; /* NONE: a delay */
            jams[n_jams].slave = (int)slave;
            jams[n_jams++].deg = deg;
            break;
        }
        case 'h': usage(stdout); return 0;
        case 'V': gonio_print_version(stdout, "gonio-sim"); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind < argc) {
        fprintf(stderr, "gonio-sim: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }

    struct gonio_err err = {0};
    struct sim_scene scene;
    struct plan_rig rig;
    int rc = sim_scene_load(scene_name, &scene, &err);
    if (rc == 0)
        rc = plan_rig_load(rig_name ? rig_name : scene.rig, &rig, &err);
    if (rc < 0) {
        fprintf(stderr, "gonio-sim: %s\n", err.msg);
        return gonio_exit_status(rc);
    }
    const char *spec = material_spec ? material_spec : scene.material;
    if (!strcmp(spec, "default"))
        spec = brdf_material_default_spec();
    brdf_material *material = brdf_material_open(spec, &err);
    if (!material) {
        fprintf(stderr, "gonio-sim: %s\n", err.msg);
        return 2;
    }
    if (check) {
        printf("scene %s (%s)\nmaterial %s\nrig %s%s\ntime scale %g\nsteps per degree %g\n"
               "IN-POS band %g deg\n", scene.name, scene.path, brdf_material_name(material),
               rig.name, rig.out_of_plane ? " (out of plane: azimuth slave 4)" : "",
               cfg.time_scale, cfg.steps_per_deg, cfg.in_pos_deg);
        const struct plan_axis *ax[3] = {&rig.sample, &rig.arm, &rig.azimuth};
        static const char *names[3] = {"sample (slave 1)", "arm (slave 2)", "azimuth (slave 4)"};
        for (int i = 0; i < (rig.out_of_plane ? 3 : 2); i++)
            printf("axis %s: limits [%g, %g] deg, profile %g deg/s, %g deg/s^2\n", names[i],
                   ax[i]->min, ax[i]->max, ax[i]->speed, ax[i]->accel);
        printf("detector (slave 3): rgb\n");
        if (cfg.baud > 0)
            printf("RTU line %ld baud\n", cfg.baud);
        if (cfg.tcp_latency_s > 0)
            printf("TCP latency %g ms\n", cfg.tcp_latency_s * 1e3);
        brdf_material_free(material);
        return 0;
    }

    struct sigaction sa = {.sa_handler = on_signal}; /* no SA_RESTART: poll returns */
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGUSR1, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);

    msim *m = msim_new(&rig, material, &scene, &cfg, &err);
    char path[256];
    int port = 0;
    rc = m ? 0 : -1;
    for (int i = 0; i < n_jams && rc == 0; i++)
        rc = jams[i].kind == MSIM_JAM_NONE
                 ? msim_delay(m, jams[i].slave, jams[i].deg, &err)
                 : msim_jam(m, jams[i].slave, jams[i].kind, jams[i].deg, &err);
    if (rc < 0 && m) {
        fprintf(stderr, "gonio-sim: %s\n", err.msg);
        msim_free(m);
        brdf_material_free(material);
        return 2;
    }
    rc = m ? msim_open_pty(m, link, path, sizeof path, &err) : -1;
    if (rc == 0 && tcp)
        rc = msim_open_tcp(m, tcp, &port, &err);
    if (rc == 0) {
        printf("%s\n", path);
        if (tcp)
            printf("tcp %.*s:%d\n", (int)(strrchr(tcp, ':') - tcp), tcp, port);
        fflush(stdout);
        /* stdout is for programs (its first line is the path); a person who
         * started it by hand learns on stderr what is served and how to stop. */
        fprintf(stderr, "gonio-sim: Modbus RTU on %s", path);
        if (tcp)
            fprintf(stderr, " and Modbus TCP on %.*s:%d", (int)(strrchr(tcp, ':') - tcp), tcp,
                    port);
        fprintf(stderr, " (scene %s, material %s, rig %s, time scale %g); Ctrl-C stops\n",
                scene.name, brdf_material_name(material), rig.name, cfg.time_scale);
        rc = msim_serve(m, &stop_flag, &hangup_flag, &err);
    }
    if (rc < 0 || !m)
        fprintf(stderr, "gonio-sim: %s\n", err.msg);
    if (m && stats) { /* written at exit: what the rig saw over its life */
        FILE *f = fopen(stats, "w");
        if (f) {
            msim_write_stats(m, f);
            fclose(f);
        } else {
            fprintf(stderr, "gonio-sim: --stats %s: cannot write\n", stats);
        }
    }
    if (link)
        remove(link);
    msim_free(m);
    brdf_material_free(material);
    return !m ? 1 : rc < 0 ? gonio_exit_status(rc) : 0;
}
