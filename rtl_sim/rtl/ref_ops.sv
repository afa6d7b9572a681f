// ref_ops: reference operators for calibrating the RTL units' measured switching activity against published
// energy per operation (Horowitz, ISSCC 2014, 45 nm: 32-bit integer add 0.1 pJ, 32-bit integer multiply 3.1 pJ).
// One operator between the operand ports and a result register: the operands come straight from the ports (in a
// datapath, from the previous stage's registers), the result is registered. No handshake: a new operation every
// clock, its result one clock later.
//   OP = 0  adder:       out_y = in_a + in_b mod 2^W            (W result bits)
//   OP = 1  multiplier:  out_y = in_a * in_b, the full product  (2W result bits, operands unsigned)
// rtl_sim/activity (rtu_rtl_activity) drives it with uniform random operands; bench/rtl_activity.sh synthesizes it
// (keys ref:add32, ref:mul32 in bench/data/rtl_area.csv).
module ref_ops #(
    parameter  int OP = 0,                       // 0: add, 1: multiply
    parameter  int W  = 32,                      // operand bits
    localparam int YW = (OP == 1) ? 2 * W : W   // result bits
) (
    input  logic          clk,
    input  logic          rst,    // synchronous, active high: clears the result register
    input  logic [ W-1:0] in_a,
    input  logic [ W-1:0] in_b,
    output logic [YW-1:0] out_y
);
  logic [YW-1:0] y;  // the operator's result, before the register
  if (OP == 1) begin : g_mul
    assign y = YW'(in_a) * YW'(in_b);
  end else begin : g_add
    assign y = in_a + in_b;
  end

  always_ff @(posedge clk) begin
    if (rst) out_y <= '0;
    else out_y <= y;
  end
endmodule
