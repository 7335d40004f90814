#include "common/version.h"

const char *gonio_version(void)
{
    return GONIO_VERSION;
}

void gonio_print_version(FILE *out, const char *program)
{
    fprintf(out, "%s %s\n", program, GONIO_VERSION);
}
