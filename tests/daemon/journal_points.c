/* Test helper: print the point index of every record of a capture journal,
 * read with journal/journal.h (CRCs checked, torn tail ignored), one a line.
 * Exit 0, or 1 with the journal's error on stderr. */
#include <stdio.h>
#include <stdlib.h>

#include "journal/journal.h"

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: journal_points SAMPLES.CSV\n");
        return 2;
    }
    struct journal_sample *s = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    if (journal_read(argv[1], &s, &n, &err) < 0) {
        fprintf(stderr, "journal_points: %s\n", err.msg);
        return 1;
    }
    for (size_t i = 0; i < n; i++)
        printf("%d\n", s[i].point);
    free(s);
    return 0;
}
