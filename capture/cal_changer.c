/* A calibration run's sample changer (capture/calibration_private.h): the
 * slot it puts in the sample's place, journalled in the run's directory
 * before the changer is asked, so that a run killed anywhere knows what
 * sits in the sample's place when it starts again, and puts the sample
 * back once it is done. */
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "capture/calibration_private.h"
#include "common/paths.h"

static void journal_path(const char *dir, char *out, size_t size)
{
    snprintf(out, size, "%s/%s", dir, CAL_CHANGER_JOURNAL);
}

int cal_changer_journalled(const char *dir)
{
    char path[4200], state[16];
    journal_path(dir, path, sizeof path);
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    int slot = -1;
    if (fscanf(f, "slot %d %15s", &slot, state) != 2 || slot < 0 || slot > CAPTURE_SLOT_TRAP)
        slot = CAPTURE_SLOT_TRAP + 1; /* torn or foreign: not known */
    fclose(f);
    return slot;
}

static int journal_slot(const char *dir, int slot, const char *state, struct gonio_err *err)
{
    char path[4200], line[64];
    journal_path(dir, path, sizeof path);
    int len = snprintf(line, sizeof line, "slot %d %s\n", slot, state);
    return gonio_write_file_atomic(path, line, (size_t)len, err);
}

int cal_changer_put(const char *dir, const struct cal_hooks *h, struct capture_devices *dev,
                    enum capture_slot slot, const char *standard, struct gonio_err *err)
{
    int rc = journal_slot(dir, (int)slot, "swapping", err);
    if (rc == 0)
        rc = h->mount(h->mount_user, dev, slot, standard, err);
    if (rc < 0)
        return rc; /* the journal says a swap was under way: the next run asks again */
    if (slot != CAPTURE_SLOT_SAMPLE)
        return journal_slot(dir, (int)slot, "in", err);
    /* The sample in its place: nothing left to undo. */
    char path[4200];
    journal_path(dir, path, sizeof path);
    if (unlink(path) < 0 && errno != ENOENT)
        return gonio_err_set(err, errno, "%s: %s", path, strerror(errno));
    return gonio_fsync_parent(path, err);
}
