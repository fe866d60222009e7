// A comment frame: a titled, coloured, resizable rectangle drawn behind the blocks (kept in the
// program's `ui.comments`; the engine never sees it). Double-click the title to rename it; the swatches
// change its colour.
import { NodeResizer, type NodeProps } from "@xyflow/react";
import { memo, useContext, useState } from "react";
import { COMMENT_COLOURS, COMMENT_MIN_SIZE } from "./annotations";
import type { NodeData } from "./graph";
import { OrganiseContext } from "./organise/context";

export const CommentFrame = memo(function CommentFrame({ id, data, selected }: NodeProps & { data: NodeData }) {
  const { editComment } = useContext(OrganiseContext);
  const title = String(data.params.title ?? "");
  const colour = String(data.params.colour ?? COMMENT_COLOURS[0]);
  const [editing, setEditing] = useState(false);
  return (
    <div className={`comment-frame ${selected ? "selected" : ""}`} data-testid={`comment-${id}`}
         style={{ borderColor: colour, background: `${colour}33` }}>
      <NodeResizer isVisible={!!selected} minWidth={COMMENT_MIN_SIZE.w} minHeight={COMMENT_MIN_SIZE.h} color={colour} />
      <div className="comment-title" style={{ background: colour }} onDoubleClick={() => setEditing(true)}>
        {editing ? (
          <input className="nodrag" autoFocus defaultValue={title} aria-label="comment title" data-testid={`comment-title-${id}`}
                 onBlur={(e) => { setEditing(false); editComment(id, { ...data.params, title: e.target.value }); }}
                 onKeyDown={(e) => { if (e.key === "Enter" || e.key === "Escape") (e.target as HTMLInputElement).blur(); }} />
        ) : <span>{title || "Comment"}</span>}
        {selected && (
          <span className="swatches nodrag">
            {COMMENT_COLOURS.map((c) => (
              <button key={c} className="swatch" style={{ background: c }} aria-label={`colour ${c}`}
                      onClick={() => editComment(id, { ...data.params, colour: c })} />
            ))}
          </span>
        )}
      </div>
    </div>
  );
});
