/* Test helper: the material's BRDF at in-plane pairs, evaluated through
 * brdf/material.h alone (no simulator, no capture engine), so a test can
 * hold a capture's journal against the truth. Reads "theta_i theta_r"
 * lines (degrees) on stdin, prints "r g b" (%.17g) a line.
 * Exit 0, 2 for a bad material or line. */
#include <stdio.h>

#include "brdf/angles.h"
#include "brdf/material.h"

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: material_values SPEC < pairs\n");
        return 2;
    }
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open(argv[1], &err);
    if (!m) {
        fprintf(stderr, "material_values: %s\n", err.msg);
        return 2;
    }
    double ti, tr;
    int got, line = 0;
    while ((got = scanf("%lf %lf", &ti, &tr)) == 2) {
        line++;
        struct brdf_pair p;
        double rgb[3];
        brdf_pair_inplane(ti, tr, &p);
        brdf_material_eval(m, &p, 1, rgb);
        printf("%.17g %.17g %.17g\n", rgb[0], rgb[1], rgb[2]);
    }
    brdf_material_free(m);
    if (got != EOF) {
        fprintf(stderr, "material_values: line %d: expected 'theta_i theta_r'\n", line + 1);
        return 2;
    }
    return 0;
}
