#!/usr/bin/env python3
"""OBJ/MTL -> glTF 2.0 (.gltf + .bin) for checking hrad's glTF loader against
its OBJ loader on the same geometry (bench/results/gltf_load.md).

usage: python3 bench/obj_to_gltf.py SCENE.obj OUT.gltf

Faces are fanned into triangles (non-indexed positions, one primitive per
material). Kd -> baseColorFactor, map_Kd -> baseColorTexture (the URI as in
the MTL: put the textures beside OUT.gltf), and Ke -> emissiveFactor *
KHR_materials_emissive_strength with emissive = Ke / pi, so that hrad's
E = pi * emissive gives back E = Ke: total area and emitted power must then
equal `hrad info SCENE.obj`'s. Only v, f, usemtl, mtllib, Kd, Ke and map_Kd
are read.
"""
import sys, json, struct, math, os
obj, out = sys.argv[1], sys.argv[2]
base = os.path.dirname(obj)
V=[]; faces={}; cur=None; mtls={}; m=None
for line in open(obj, errors='replace'):
    t=line.split()
    if not t: continue
    if t[0]=='v': V.append(tuple(map(float,t[1:4])))
    elif t[0]=='usemtl': cur=t[1]
    elif t[0]=='mtllib':
        for l in open(os.path.join(base,t[1]), errors='replace'):
            u=l.split()
            if not u: continue
            if u[0]=='newmtl': m=u[1]; mtls[m]={}
            elif u[0] in ('Kd','Ke'): mtls[m][u[0]]=list(map(float,u[1:4]))
            elif u[0]=='map_Kd': mtls[m]['map']=u[-1]
    elif t[0]=='f':
        idx=[int(x.split('/')[0]) for x in t[1:]]
        idx=[i-1 if i>0 else len(V)+i for i in idx]
        for k in range(1,len(idx)-1): faces.setdefault(cur,[]).append((idx[0],idx[k],idx[k+1]))
buf=bytearray(); views=[]; accs=[]; prims=[]; mats=[]; images=[]; textures=[]
for name,tris in faces.items():
    off=len(buf); lo=[1e30]*3; hi=[-1e30]*3
    for tri in tris:
        for i in tri:
            buf+=struct.pack('<3f',*V[i]); lo=[min(a,b) for a,b in zip(lo,V[i])]; hi=[max(a,b) for a,b in zip(hi,V[i])]
    views.append({"buffer":0,"byteOffset":off,"byteLength":len(buf)-off})
    accs.append({"bufferView":len(views)-1,"componentType":5126,"count":3*len(tris),"type":"VEC3","min":lo,"max":hi})
    mm=mtls.get(name,{}); kd=mm.get('Kd',[0.5]*3); ke=mm.get('Ke',[0,0,0])
    s=max(ke)/math.pi; mat={"name":name or "none","pbrMetallicRoughness":{"baseColorFactor":kd+[1]}}
    if s>0:
        mat["emissiveFactor"]=[k/math.pi/s for k in ke]
        mat["extensions"]={"KHR_materials_emissive_strength":{"emissiveStrength":s}}
    if 'map' in mm:
        if {"uri":mm['map']} not in images:  # one image (and texture) per file
            images.append({"uri":mm['map']}); textures.append({"source":len(images)-1})
        mat["pbrMetallicRoughness"]["baseColorTexture"]={"index":images.index({"uri":mm['map']})}
    mats.append(mat)
    prims.append({"attributes":{"POSITION":len(accs)-1},"material":len(mats)-1})
open(out+'.bin','wb').write(buf)
j={"asset":{"version":"2.0"},"extensionsUsed":["KHR_materials_emissive_strength"],"buffers":[{"byteLength":len(buf),"uri":os.path.basename(out)+'.bin'}],
 "bufferViews":views,"accessors":accs,"materials":mats,"meshes":[{"primitives":prims}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0}
if images: j["images"]=images; j["textures"]=textures
json.dump(j,open(out,'w'))
