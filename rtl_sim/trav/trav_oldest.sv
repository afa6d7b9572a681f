// trav_oldest: the traversal unit's arbiter (trav_unit.sv). Among the SLOTS requests it grants the one with the
// smallest time stamp, ties to the lowest slot; win[SW] is set when nothing is requested. Its own module so that
// synthesis reports the scheduler's area apart (bench/rtl_trav_area.sh).
module trav_oldest #(
    parameter int SLOTS = 4,
    localparam int SW   = SLOTS > 1 ? $clog2(SLOTS) : 1
) (
    input  logic [      SLOTS-1:0] req,
    input  logic [   SLOTS*32-1:0] t,    // slot k's time stamp at [32*k +: 32]
    output logic [           SW:0] win   // {none, slot}
);
  always_comb begin
    win = {1'b1, SW'(0)};
    for (int k = 0; k < SLOTS; k++)
      if (req[k] && (win[SW] || t[32*k+:32] < t[32*win[SW-1:0]+:32])) win = {1'b0, SW'(k)};
  end
endmodule
