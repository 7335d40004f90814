/* gonio-sim: the simulated gonioreflectometer as its own process, serving
 * the rig's Modbus bus (docs/gonio-sim.md). A thin shell: options, scene,
 * signals; the server of sim/modbus_server.h does the rest. */
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
#include "sim/standard_draw.h"

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
            "                 [--time-scale K | --clock simulated] [--steps-per-deg N]\n"
            "                 [--in-pos-deg D]\n"
            "                 [--link PATH]\n"
            "                 [--tcp 127.0.0.1:PORT] [--trace] [--check]\n"
            "                 [--stall SLAVE:DEG] [--overload SLAVE:DEG] [--delay SLAVE:MS]\n"
            "                 [--stats FILE] [--baud N] [--tcp-latency MS] [--no-shutter]\n"
            "       gonio-sim --version\n"
            "  Serves the rig's Modbus bus (docs/protocol-modbus.md) as RTU on a new\n"
            "  pseudo-terminal, whose path is the first line on stdout, and with --tcp\n"
            "  also as Modbus TCP (second line: 'tcp HOST:PORT'; PORT 0 picks one).\n"
            "  Simulated time runs K times faster than wall time (default 1); with\n"
            "  --clock simulated it advances only by what the simulator models (moves,\n"
            "  integrations, bus time, waits the master asks for), never by wall time,\n"
            "  and a poll for a move's or an integration's end finds it ended. The drives\n"
            "  report IN-POS within D deg of their target (default 0.05).\n"
            "  --check prints the resolved setup and exits. --stall and --overload put an\n"
            "  obstacle on an axis: moves across it halt there, still moving (stall) or\n"
            "  with alarm 0x30 (overload). --delay makes a slave answer MS ms late.\n"
            "  --stats writes, at exit, the exchanges, the faults injected and each axis's\n"
            "  commanded and reached range as JSON.\n"
            "  --baud makes each RTU exchange take its frames' time on a serial line at N\n"
            "  baud, --tcp-latency each TCP reply MS ms, both in rig time; with --baud a\n"
            "  master that set the pty to another speed gets no answer (framing errors).\n"
            "  --no-shutter serves a detector without the shutter register (exception 02).\n"
            "  SIGUSR1 closes every TCP connection (a network drop).\n"
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

/* What the command line asked for. Faults are kept until the server
 * exists: --stall, --overload, and --delay (kind NONE, deg holding the ms). */
struct sim_opts {
    const char *scene_name, *material_spec, *rig_name, *link, *tcp, *stats;
    struct msim_cfg cfg;
    int check, n_jams, scale_given;
    struct {
        enum msim_jam_kind kind;
        int slave;
        double deg;
    } jams[4];
};

/* What the options resolved to: the scene, the rig profile and the
 * material the server simulates. */
struct sim_setup {
    struct sim_scene scene;
    struct rig_profile rig;
    brdf_material *material;
};

enum { GO_ON = -1 }; /* a step's return when the program goes on, else its exit status */

/* --stall, --overload or --delay (c 'S', 'O', 'D'): SLAVE:DEG or SLAVE:MS. */
static int parse_fault(int c, const char *arg, struct sim_opts *o)
{
    char *end;
    long slave = strtol(arg, &end, 10);
    double deg = *end == ':' ? strtod(end + 1, &end) : NAN;
    if (*end || !isfinite(deg) || o->n_jams == 4) {
        fprintf(stderr, "gonio-sim: --%s '%s': expected SLAVE:%s\n",
                c == 'S' ? "stall" : c == 'O' ? "overload" : "delay", arg,
                c == 'D' ? "MS" : "DEG");
        return -1;
    }
    o->jams[o->n_jams].kind = c == 'S' ? MSIM_JAM_STALL
                              : c == 'O' ? MSIM_JAM_OVERLOAD
                                         : MSIM_JAM_NONE; /* NONE: a delay */
    o->jams[o->n_jams].slave = (int)slave;
    o->jams[o->n_jams++].deg = deg;
    return 0;
}

static int parse_baud(const char *arg, long *baud)
{
    double v;
    if (parse_positive("--baud", arg, &v) < 0)
        return -1;
    if (v != floor(v)) {
        fprintf(stderr, "gonio-sim: --baud '%s': expected a whole number\n", arg);
        return -1;
    }
    if (!msim_line_speed((long)v)) {
        fprintf(stderr, "gonio-sim: --baud '%s': not a speed a serial line is set to (1200, "
                "9600, 19200, 38400, 57600, 115200, ...)\n", arg);
        return -1;
    }
    *baud = (long)v;
    return 0;
}

/* --clock wall|simulated. */
static int parse_clock(const char *arg, int *simulated)
{
    if (strcmp(arg, "wall") && strcmp(arg, "simulated")) {
        fprintf(stderr, "gonio-sim: --clock '%s': expected wall or simulated\n", arg);
        return -1;
    }
    *simulated = !strcmp(arg, "simulated");
    return 0;
}

/* GO_ON, or the exit status: 0 after --help or --version, 2 on a bad option. */
static int parse_options(int argc, char **argv, struct sim_opts *o)
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
        {"in-pos-deg", required_argument, NULL, 'i'}, {"clock", required_argument, NULL, 'C'},
        {"version", no_argument, NULL, 'V'},
        {"no-shutter", no_argument, NULL, 'N'},
        {NULL, 0, NULL, 0},
    };
    int c, bad = 0;
    while (!bad && (c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        switch (c) {
        case 's': o->scene_name = optarg; break;
        case 'm': o->material_spec = optarg; break;
        case 'r': o->rig_name = optarg; break;
        case 'k':
            bad = parse_positive("--time-scale", optarg, &o->cfg.time_scale) < 0;
            o->scale_given = 1;
            break;
        case 'C': bad = parse_clock(optarg, &o->cfg.simulated_clock) < 0; break;
        case 'n': bad = parse_positive("--steps-per-deg", optarg, &o->cfg.steps_per_deg) < 0; break;
        case 'i': bad = parse_positive("--in-pos-deg", optarg, &o->cfg.in_pos_deg) < 0; break;
        case 'l': o->link = optarg; break;
        case 't': o->tcp = optarg; break;
        case 'T': o->cfg.trace = 1; break;
        case 'X': o->stats = optarg; break;
        case 'b': bad = parse_baud(optarg, &o->cfg.baud) < 0; break;
        case 'L':
            bad = parse_positive("--tcp-latency", optarg, &o->cfg.tcp_latency_s) < 0;
            o->cfg.tcp_latency_s *= 1e-3;
            break;
        case 'c': o->check = 1; break;
        case 'N': o->cfg.no_shutter = 1; break;
        case 'S':
        case 'D':
        case 'O': bad = parse_fault(c, optarg, o) < 0; break;
        case 'h': usage(stdout); return 0;
        case 'V': gonio_print_version(stdout, "gonio-sim"); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (bad)
        return 2;
    if (o->scale_given && o->cfg.simulated_clock) {
        fprintf(stderr, "gonio-sim: --time-scale with --clock simulated: a simulated clock "
                "follows no wall time, so it has no scale; give one or the other\n");
        return 2;
    }
    if (optind < argc) {
        fprintf(stderr, "gonio-sim: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    return GO_ON;
}

/* Load the scene, the rig (--rig, else the scene's) and the material
 * (--material, else the scene's). GO_ON, or the exit status. */
static int load_setup(const struct sim_opts *o, struct sim_setup *su)
{
    struct gonio_err err = {0};
    int rc = sim_scene_load(o->scene_name, &su->scene, &err);
    if (rc == 0)
        rc = rig_profile_load(o->rig_name ? o->rig_name : su->scene.rig, &su->rig, &err);
    if (rc < 0) {
        fprintf(stderr, "gonio-sim: %s\n", err.msg);
        return gonio_exit_status(rc);
    }
    const char *spec = o->material_spec ? o->material_spec : su->scene.material;
    if (!strcmp(spec, "default"))
        spec = brdf_material_default_spec();
    su->material = sim_material_open(&su->scene, spec, &err);
    if (!su->material) {
        fprintf(stderr, "gonio-sim: %s\n", err.msg);
        return 2;
    }
    return GO_ON;
}

/* --check: the resolved setup, on stdout. */
static void print_setup(const struct sim_opts *o, const struct sim_setup *su)
{
    const struct msim_cfg *cfg = &o->cfg;
    const struct rig_profile *rig = &su->rig;
    printf("scene %s (%s)\nmaterial %s\nrig %s%s%s\n", su->scene.name, su->scene.path,
           brdf_material_name(su->material), rig->name,
           rig->out_of_plane ? " (out of plane: azimuth slave 4)" : "",
           rig->has_rotation ? " (sample rotation: slave 5)" : "");
    if (cfg->simulated_clock)
        printf("clock simulated\n");
    else
        printf("time scale %g\n", cfg->time_scale);
    printf("steps per degree %g\nIN-POS band %g deg\n", cfg->steps_per_deg, cfg->in_pos_deg);
    const struct rig_axis *ax[4] = {&rig->sample, &rig->arm, &rig->azimuth, &rig->rotation};
    const int has[4] = {1, 1, rig->out_of_plane, rig->has_rotation};
    static const char *names[4] = {"sample (slave 1)", "arm (slave 2)", "azimuth (slave 4)",
                                   "rotation (slave 5)"};
    for (int i = 0; i < 4; i++)
        if (has[i])
            printf("axis %s: limits [%g, %g] deg, profile %g deg/s, %g deg/s^2\n", names[i],
                   ax[i]->min, ax[i]->max, ax[i]->speed, ax[i]->accel);
    printf("detector (slave 3): rgb%s\n", cfg->no_shutter ? ", no shutter register" : "");
    if (cfg->baud > 0)
        printf("RTU line %ld baud\n", cfg->baud);
    if (cfg->tcp_latency_s > 0)
        printf("TCP latency %g ms\n", cfg->tcp_latency_s * 1e3);
}

static void install_signals(void)
{
    struct sigaction sa = {.sa_handler = on_signal}; /* no SA_RESTART: poll returns */
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGUSR1, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);
}

static int inject_faults(msim *m, const struct sim_opts *o, struct gonio_err *err)
{
    int rc = 0;
    for (int i = 0; i < o->n_jams && rc == 0; i++)
        rc = o->jams[i].kind == MSIM_JAM_NONE
                 ? msim_delay(m, o->jams[i].slave, o->jams[i].deg, err)
                 : msim_jam(m, o->jams[i].slave, o->jams[i].kind, o->jams[i].deg, err);
    return rc;
}

/* Open the pseudo-terminal (and the TCP port), say what is served, and
 * answer requests until a signal stops the server. */
static int serve(msim *m, const struct sim_opts *o, const struct sim_setup *su,
                 struct gonio_err *err)
{
    char path[256];
    int port = 0;
    const char *tcp = o->tcp;
    int rc = msim_open_pty(m, o->link, path, sizeof path, err);
    if (rc == 0 && tcp)
        rc = msim_open_tcp(m, tcp, &port, err);
    if (rc < 0)
        return rc;
    printf("%s\n", path);
    if (tcp)
        printf("tcp %.*s:%d\n", (int)(strrchr(tcp, ':') - tcp), tcp, port);
    fflush(stdout);
    /* stdout is for programs (its first line is the path); a person who
     * started it by hand learns on stderr what is served and how to stop. */
    fprintf(stderr, "gonio-sim: Modbus RTU on %s", path);
    if (tcp)
        fprintf(stderr, " and Modbus TCP on %.*s:%d", (int)(strrchr(tcp, ':') - tcp), tcp, port);
    fprintf(stderr, " (scene %s, material %s, rig %s, ", su->scene.name,
            brdf_material_name(su->material), su->rig.name);
    if (o->cfg.simulated_clock)
        fprintf(stderr, "simulated clock); Ctrl-C stops\n");
    else
        fprintf(stderr, "time scale %g); Ctrl-C stops\n", o->cfg.time_scale);
    return msim_serve(m, &stop_flag, &hangup_flag, err);
}

/* Written at exit: what the rig saw over its life. */
static void write_stats(const msim *m, const char *path)
{
    FILE *f = fopen(path, "w");
    if (f) {
        msim_write_stats(m, f);
        fclose(f);
    } else {
        fprintf(stderr, "gonio-sim: --stats %s: cannot write\n", path);
    }
}

/* The server's life: made, faults injected, served, stats written,
 * freed. Takes the material. The exit status. */
static int run_server(const struct sim_opts *o, struct sim_setup *su)
{
    struct gonio_err err = {0};
    msim *m = msim_new(&su->rig, su->material, &su->scene, &o->cfg, &err);
    int rc = m ? inject_faults(m, o, &err) : -1;
    if (rc < 0 && m) {
        fprintf(stderr, "gonio-sim: %s\n", err.msg);
        msim_free(m);
        brdf_material_free(su->material);
        return 2;
    }
    rc = m ? serve(m, o, su, &err) : -1;
    if (rc < 0 || !m)
        fprintf(stderr, "gonio-sim: %s\n", err.msg);
    if (m && o->stats)
        write_stats(m, o->stats);
    if (o->link)
        remove(o->link);
    msim_free(m);
    brdf_material_free(su->material);
    return !m ? 1 : rc < 0 ? gonio_exit_status(rc) : 0;
}

int main(int argc, char **argv)
{
    /* IN-POS band: the AZ's initial 1.8 deg at the motor (docs/gonio-sim.md)
     * through the 36:1 reduction that 100 steps/deg at 1000 steps/rev means. */
    struct sim_opts o = {.scene_name = "ideal",
                         .cfg = {.time_scale = 1.0, .steps_per_deg = 100.0, .in_pos_deg = 0.05}};
    int status = parse_options(argc, argv, &o);
    if (status != GO_ON)
        return status;
    struct sim_setup su;
    status = load_setup(&o, &su);
    if (status != GO_ON)
        return status;
    if (o.check) {
        print_setup(&o, &su);
        brdf_material_free(su.material);
        return 0;
    }
    install_signals();
    return run_server(&o, &su);
}
