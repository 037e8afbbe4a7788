//! Files put in place by a hard link, never following one: a finished
//! shard's file taken by `swarmshot merge` (or copied when a link cannot be
//! made), and a frame's file linked to another name within the folder.

use super::*;

impl Folder {
    /// Put the file `rel` of the shard `shard` (outside the folder, for
    /// `swarmshot merge`) at `rel`: a hard link (`linkat` relative to the
    /// shard folder's handle, never following a link) unless `copy` or the
    /// file system refuses one, else a copy flushed to disk; made under the
    /// temporary name and renamed into place like every other file. `seen`
    /// is the (device, inode) the shard's file had when its content was
    /// checked: a file replaced since is refused. Returns whether it was linked.
    pub fn link_file(
        &mut self,
        rel: &str,
        shard: &mut Tree,
        seen: (u64, u64),
        copy: bool,
    ) -> Result<bool, OutputError> {
        if let Some((dir, _)) = rel.rsplit_once('/') {
            self.ensure_dir(dir)?;
        }
        self.check_target(rel)?;
        if !self.is_ours(rel) {
            self.claim(&[rel])?;
        }
        let src = shard.root().join(rel);
        let replaced = || refused(src.clone(), "was replaced after its content was checked");
        match shard.lstat(rel)? {
            Some(e) if e.is_file() && (e.dev, e.ino) == seen => {}
            Some(e) if e.is_symlink() => return Err(link_refused(src)),
            Some(_) => return Err(replaced()),
            None => return Err(refused(src, "is missing (the shard's ledger records it)")),
        }
        let path = self.root.join(rel);
        // Linked by an interrupted merge already (a rename onto another link
        // of the same file would do nothing and leave the temporary name).
        if !copy
            && self
                .tree
                .lstat(rel)?
                .is_some_and(|m| (m.dev, m.ino) == seen)
        {
            return Ok(true);
        }
        let tmp_rel = self.clear_temp(rel)?;
        let linked = !copy && shard.link_into(rel, &mut self.tree, &tmp_rel).is_ok();
        if linked
            && self
                .tree
                .lstat(&tmp_rel)?
                .is_none_or(|m| (m.dev, m.ino) != seen)
        {
            let _ = self.tree.remove_file(&tmp_rel);
            return Err(replaced());
        }
        let mut from = if linked {
            None
        } else {
            let from = shard.open_file(rel, false)?;
            if Tree::identity(&from) != Some(seen) {
                return Err(replaced());
            }
            Some(from)
        };
        let copied = match &mut from {
            Some(from) => self.tree.create_new(&tmp_rel, false).and_then(|mut to| {
                std::io::copy(from, &mut to)
                    .and_then(|_| to.sync_all())
                    .map_err(io(&path))
            }),
            None => Ok(()),
        };
        stall_if_asked(rel);
        let result = copied.and_then(|()| self.tree.rename(&tmp_rel, rel));
        if result.is_err() {
            let _ = self.tree.remove_file(&tmp_rel);
        }
        result?;
        Ok(linked)
    }

    /// Hard-link the dataset's file `from` to `to` (both inside the folder),
    /// claimed with the frame's files before it is made (a frame remade by
    /// `--resume` drops it with them), never following a link.
    pub fn link_frame_file(&mut self, from: &str, to: &str) -> Result<(), OutputError> {
        if let Some((dir, _)) = to.rsplit_once('/') {
            self.ensure_dir(dir)?;
        }
        self.claim_frame(&[to.to_owned()])?;
        self.remove(to)?;
        self.tree.link_within(from, to)
    }
}
