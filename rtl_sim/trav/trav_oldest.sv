// trav_oldest: the traversal unit's arbiter (trav_unit.sv). Among the SLOTS requests it grants the one with the
// smallest time stamp, ties to the lowest slot; win[SW] is set when nothing is requested. A tree of pairwise
// choices (the left, lower-numbered side on a tie), so its size grows with SLOTS, not with its square. Its own
// module so that synthesis reports the scheduler's area apart (bench/rtl_trav_area.sh).
module trav_oldest #(
    parameter int SLOTS = 4,
    localparam int SW   = SLOTS > 1 ? $clog2(SLOTS) : 1,
    localparam int P    = 1 << SW  // leaves: SLOTS rounded up to a power of two
) (
    input  logic [      SLOTS-1:0] req,
    input  logic [   SLOTS*32-1:0] t,    // slot k's time stamp at [32*k +: 32]
    output logic [           SW:0] win   // {none, slot}
);
  // Node n of the tree (1 the root, 2n and 2n+1 its children, P + k slot k's leaf): whether a request is below
  // it, the oldest one's stamp and slot.
  logic          v [2*P];
  logic [  31:0] ts[2*P];
  logic [SW-1:0] id[2*P];
  always_comb begin
    v[0] = 1'b0;
    ts[0] = '0;
    id[0] = '0;
    for (int k = 0; k < P; k++) begin
      v[P+k] = k < SLOTS ? req[k] : 1'b0;
      ts[P+k] = k < SLOTS ? t[32*k+:32] : '0;
      id[P+k] = SW'(k);
    end
    for (int n = P - 1; n >= 1; n--) begin
      if (v[2*n] && (!v[2*n+1] || !(ts[2*n+1] < ts[2*n]))) begin
        v[n] = 1'b1;
        ts[n] = ts[2*n];
        id[n] = id[2*n];
      end else begin
        v[n] = v[2*n+1];
        ts[n] = ts[2*n+1];
        id[n] = id[2*n+1];
      end
    end
    win = {!v[1], v[1] ? id[1] : SW'(0)};
  end
endmodule
